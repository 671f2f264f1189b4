"""Coarse stages on local HOG descriptors: histograms of oriented gradients around each landmark.

Pixel-difference features (:mod:`~aamcore.fitting.algorithm.ferns`)
are precise near the answer but have a small basin: from a Haar start (its
scale, position and, above all, its missing in-plane rotation) they leave
one face in eight far off. Gradient histograms over a window around each
landmark, as in supervised descent with SIFT (Xiong & De la Torre 2013),
tolerate the large first errors. The face is first brought to a canonical
size and orientation by the similarity of the current shape (one
:func:`cv2.warpAffine` of a small canvas), and OpenCV's HOG descriptor is
computed at the landmarks; one linear regression maps the descriptors to a
step in the shape basis (:class:`~aamcore.fitting.shape_space.ShapeSpace`).
These stages run only from a detection (acquisition), not while tracking.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np


@dataclass(frozen=True)
class HogStage:
    """One linear regression on landmark HOG descriptors.

    Attributes
    ----------
    iod : float
        Eye-corner distance of the mean shape on the canonical canvas (pixels).
    window : int
        Side of the square HOG window centred on each landmark (canvas
        pixels); ``cells`` x ``cells`` cells of 9 orientation bins, one block.
    cells : int
    feature_mean : (D,) float32 array
        Mean descriptor of the training samples (``D = 36 N`` for 2 x 2 cells).
    weights : (D, Q) float32 array
    bias : (Q,) float32 array
    """

    iod: float
    window: int
    cells: int
    feature_mean: np.ndarray
    weights: np.ndarray
    bias: np.ndarray

    def __post_init__(self) -> None:
        if not (self.iod > 0 and self.window >= 8 and self.cells >= 1
                and self.window % self.cells == 0):
            raise ValueError(f"HOG stage: iod {self.iod}, window {self.window} and cells "
                             f"{self.cells} are not usable")
        if self.weights.shape != (self.feature_mean.size, self.bias.size):
            raise ValueError(f"HOG stage weights {self.weights.shape} do not fit features "
                             f"{self.feature_mean.shape} and bias {self.bias.shape}")

    def arrays(self, prefix: str) -> dict[str, np.ndarray]:
        """The stage as named arrays for a model file."""
        return {
            f"{prefix}_meta": np.array([self.iod, self.window, self.cells], dtype=np.float64),
            f"{prefix}_feature_mean": self.feature_mean,
            f"{prefix}_weights": self.weights,
            f"{prefix}_bias": self.bias,
        }

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], prefix: str) -> HogStage:
        """The stage written by :meth:`arrays`."""
        iod, window, cells = arrays[f"{prefix}_meta"]
        return cls(
            float(iod),
            int(window),
            int(cells),
            np.asarray(arrays[f"{prefix}_feature_mean"], np.float32),
            np.asarray(arrays[f"{prefix}_weights"], np.float32),
            np.asarray(arrays[f"{prefix}_bias"], np.float32),
        )


class LandmarkHog:
    """HOG descriptors at the landmarks of a similarity-normalised face.

    Parameters
    ----------
    mean : (N, 2) array
        The shape model's mean shape, centred.
    iod : float
        Canonical eye-corner distance (canvas pixels).
    window, cells : int
        See :class:`HogStage`.
    unit : float
        The mean shape's eye-corner distance
        (:attr:`~aamcore.fitting.shape_space.ShapeSpace.eye_distance`).
    """

    def __init__(self, mean: np.ndarray, iod: float, window: int, cells: int, unit: float
                 ) -> None:
        mean = np.asarray(mean, dtype=np.float64)
        self.mean = mean
        norm = float(np.sum(mean * mean))
        self._sim = (
            np.stack([mean.ravel(), np.stack([-mean[:, 1], mean[:, 0]], 1).ravel()]) / norm
        ).T
        self.k = iod / unit
        self.window = int(window)
        cell = self.window // cells
        self.hog = cv2.HOGDescriptor(
            (self.window, self.window), (self.window, self.window), (cell, cell), (cell, cell), 9
        )
        self.size = int(np.max(np.ptp(mean, axis=0)) * self.k * 1.6) + 2 * self.window
        self.size_per_landmark = int(self.hog.getDescriptorSize())

    def step(self, stage: HogStage, image: np.ndarray, shape: np.ndarray) -> np.ndarray:
        """The regression output (Q,) float64 of ``stage`` at ``shape`` (N, 2)."""
        x = self(image, shape)
        return ((x - stage.feature_mean) @ stage.weights + stage.bias).astype(np.float64)

    def canvas_transform(self, shape: np.ndarray) -> np.ndarray:
        """2x3 matrix taking image points to the canonical canvas of ``shape`` (N, 2).

        With ``shape ~ mean @ L + centre``, ``L = [[a, b], [-b, a]]``, a point
        ``x`` goes to ``(x - centre) @ inv(L) * k + size / 2``.
        """
        a, b = shape.ravel() @ self._sim
        centre = shape.mean(axis=0)
        lin = np.array([[a, -b], [b, a]]).T * (self.k / (a * a + b * b))
        m = np.empty((2, 3))
        m[:, :2] = lin
        m[:, 2] = self.size / 2 - lin @ centre
        return m

    def __call__(self, image: np.ndarray, shape: np.ndarray) -> np.ndarray:
        """Descriptor (N * 36,) float32 of grey or BGR ``image`` at ``shape`` (N, 2)."""
        m = self.canvas_transform(shape)
        canvas = cv2.warpAffine(
            image,
            m,
            (self.size, self.size),
            flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_REPLICATE,
        )
        if canvas.ndim == 3:
            canvas = cv2.cvtColor(canvas, cv2.COLOR_BGR2GRAY)
        points = shape @ m[:, :2].T + m[:, 2]
        corner = np.rint(points - self.window / 2).astype(np.int64)
        np.clip(corner, 0, self.size - self.window, out=corner)
        locations = [(int(x), int(y)) for x, y in corner]
        return self.hog.compute(canvas, (self.window, self.window), (0, 0), locations).ravel()
