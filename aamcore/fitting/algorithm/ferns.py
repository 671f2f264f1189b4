"""Ferns on pixel differences: the local binary features of one cascade stage.

Ren, Cao, Wei and Sun 2014 ("Face Alignment at 3000 FPS via Regressing Local
Binary Features") with Cao et al.'s ferns: every landmark has a few ferns, each
a fixed sequence of ``depth`` tests ``I(p1) - I(p2) > threshold`` on two pixels
placed around that landmark in the frame of the current shape. The outcomes of
a fern's tests, read as a binary number, are its leaf: one bit of a sparse
binary feature vector, and one linear regression from all bits gives the step
of the whole shape. As a fern shares one test per level, all tests of a stage
are sampled in one vectorised pass (no level-by-level traversal).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FernStage:
    """One stage: ``T`` ferns of one depth and the regression from their leaves.

    The ferns are grouped by landmark, the same number for each: fern ``t``
    belongs to landmark ``t // (T / N)``.

    Attributes
    ----------
    anchors : (T,) int64 array
        Landmark around which fern ``t`` samples its pixels.
    offsets : (T * depth, 4) float32 array
        Test ``k`` of fern ``t`` at row ``t * depth + k``: its two pixels
        ``(x1, y1, x2, y2)`` relative to the anchor landmark, in model-frame
        units (mapped to the image by the similarity of the current shape).
    thresholds : (T * depth,) float32 array
        A test passes where ``I(p1) - I(p2) > threshold``.
    weights : (T * 2**depth, Q) float32 array
        Row ``t * 2**depth + leaf``: what reaching that leaf adds to the output.
    bias : (Q,) float32 array
        The output's constant part.
    depth : int
    radius : float
        Largest pixel offset of the stage (model-frame units).
    """

    anchors: np.ndarray
    offsets: np.ndarray
    thresholds: np.ndarray
    weights: np.ndarray
    bias: np.ndarray
    depth: int
    radius: float

    def __post_init__(self) -> None:
        t, d = len(self.anchors), self.depth
        if t == 0 or self.offsets.shape != (t * d, 4) or self.thresholds.shape != (t * d,):
            raise ValueError(f"fern stage of {t} ferns of depth {d} has offsets "
                             f"{self.offsets.shape} and thresholds {self.thresholds.shape}")
        if self.weights.shape[0] != t * 2**d or self.bias.shape != self.weights.shape[1:]:
            raise ValueError(f"fern stage weights {self.weights.shape} and bias "
                             f"{self.bias.shape} do not fit {t} ferns of depth {d}")
        n_points = int(self.anchors.max()) + 1
        if t % n_points or not np.array_equal(
                self.anchors, np.repeat(np.arange(n_points), t // n_points)):
            raise ValueError("the ferns of a stage must be grouped by landmark, as many for each")

    @property
    def n_ferns(self) -> int:
        return len(self.anchors)

    @property
    def n_points(self) -> int:
        return int(self.anchors.max()) + 1

    def arrays(self, prefix: str) -> dict[str, np.ndarray]:
        """The stage as named arrays for a model file."""
        return {
            f"{prefix}_anchors": self.anchors, f"{prefix}_offsets": self.offsets,
            f"{prefix}_thresholds": self.thresholds, f"{prefix}_weights": self.weights,
            f"{prefix}_bias": self.bias,
            f"{prefix}_meta": np.array([self.depth, self.radius], dtype=np.float64),
        }

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], prefix: str) -> FernStage:
        """The stage written by :meth:`arrays`."""
        depth, radius = arrays[f"{prefix}_meta"]
        return cls(
            np.asarray(arrays[f"{prefix}_anchors"], dtype=np.int64),
            np.asarray(arrays[f"{prefix}_offsets"], dtype=np.float32),
            np.asarray(arrays[f"{prefix}_thresholds"], dtype=np.float32),
            np.asarray(arrays[f"{prefix}_weights"], dtype=np.float32),
            np.asarray(arrays[f"{prefix}_bias"], dtype=np.float32),
            int(depth), float(radius),
        )


class FernRunner:
    """A :class:`FernStage` laid out for speed: all its tests sampled in one pass.

    The test pixels are held as (coordinate, point of the pair, landmark, test)
    so that the landmark positions broadcast instead of being gathered; the
    thresholds as int16 (pixel differences are integers: ``d > t`` exactly when
    ``d > floor(t)``); the weights as float32.

    Parameters
    ----------
    stage : FernStage
    """

    def __init__(self, stage: FernStage) -> None:
        self.stage = stage
        n, d = stage.n_points, stage.depth
        k = stage.n_ferns // n * d
        tests = stage.offsets.reshape(n, k, 2, 2)  # landmark, test, point, xy
        self.offsets = np.ascontiguousarray(np.transpose(tests, (3, 2, 0, 1)).reshape(2, -1),
                                            dtype=np.float64)
        self.shape4 = (2, 2, n, k)
        self.thresholds = np.floor(np.clip(stage.thresholds, -32768, 32767)).astype(np.int16)
        self.powers = 1 << np.arange(d, dtype=np.intp)
        self.leaf_base = np.arange(stage.n_ferns, dtype=np.intp) * 2**d
        self.weights = np.ascontiguousarray(stage.weights, dtype=np.float32)
        self.bias = stage.bias.astype(np.float32)
        self.ones = np.ones(stage.n_ferns, dtype=np.float32)

    def values(self, pixels: np.ndarray, width: int, limit: tuple[float, float],
               shape: np.ndarray, rot: np.ndarray) -> np.ndarray:
        """The test pixels (2, T depth) uint8 of every test at ``shape`` (N, 2).

        ``pixels`` is a flat grey region ``width`` pixels wide, ``limit`` its
        ``(w - 1, h - 1)``, ``shape`` in region pixels, ``rot`` the 2x2
        ``[[a, -b], [b, a]]`` of the shape's similarity (model frame to image).
        """
        p = (rot @ self.offsets).reshape(self.shape4)
        p += (shape.T + 0.5)[:, None, :, None]
        x = p[0].clip(0.0, limit[0]).astype(np.intp)
        y = p[1].clip(0.0, limit[1]).astype(np.intp)
        return pixels.take(x + y * width).reshape(2, -1)

    def values_of(self, pixels: np.ndarray, width: int, limit: tuple[float, float],
                  shapes: np.ndarray, rots: np.ndarray) -> np.ndarray:
        """:meth:`values` of several shapes (S, N, 2) at once, ``rots`` (S, 2, 2): (S, 2,
        T depth) uint8."""
        count = len(shapes)
        p = (rots @ self.offsets).reshape((count, *self.shape4))
        p += (shapes.transpose(0, 2, 1) + 0.5)[:, :, None, :, None]
        x = p[:, 0].clip(0.0, limit[0]).astype(np.intp)
        y = p[:, 1].clip(0.0, limit[1]).astype(np.intp)
        return pixels.take(x + y * width).reshape(count, 2, -1)

    def outputs(self, values: np.ndarray) -> np.ndarray:
        """:meth:`output` of several shapes' values (S, 2, T depth): (S, Q) float64."""
        passed = np.subtract(values[:, 0], values[:, 1], dtype=np.int16) > self.thresholds
        leaf = passed.reshape(len(values), -1, self.stage.depth) @ self.powers + self.leaf_base
        return (self.ones @ self.weights.take(leaf, axis=0) + self.bias).astype(np.float64)

    def output(self, values: np.ndarray) -> np.ndarray:
        """The stage's output (Q,) float64 from the test pixels of :meth:`values`."""
        passed = np.subtract(values[0], values[1], dtype=np.int16) > self.thresholds
        leaf = passed.reshape(-1, self.stage.depth) @ self.powers + self.leaf_base
        return (self.ones @ self.weights.take(leaf, axis=0) + self.bias).astype(np.float64)
