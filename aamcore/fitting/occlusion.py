"""Which landmarks are covered: read from the texture residual of the triangles around each.

An AAM fit leaves the texture residual ``r = g - g_model(c)`` of every
reference-frame pixel. Where something covers the face, the texture there
is not a face's: a patterned occluder leaves a residual the model cannot
explain, and a smooth one (a hand) takes away the contrast a face has at the
eyes, brows, nose and lips, which the residual alone, small over a flat
patch, does not show. So for each triangle of the reference frame four
numbers are read from the fit: the log energy of the residual, its mean, and
the log variance and log gradient energy of the texture seen (``r + g_model(c)``).
Each is standardised by what that triangle shows on unoccluded faces, and a
logistic model learned on faces with drawn occluders
(:mod:`aamcore.fitting.training.occlusion`) turns them into the probability
that the triangle is covered. A landmark's part of the face is the triangles
around it: it is flagged when their area-weighted mean probability is above the
learned threshold.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np
from scipy import sparse

from aamcore.fitting.result import AAMFit
from aamcore.model.aam import AAM
from aamcore.warp.reference_frame import ReferenceFrame

FEATURES = ("log_residual_energy", "mean_residual", "log_variance", "log_gradient_energy")
"""What is read from each triangle, in this order."""
EPS = 1e-4
"""Added before the logarithms (normalised texture units squared)."""


@dataclass(frozen=True)
class OcclusionModel:
    """What the occlusion test learned (a part of the fitting model file).

    Attributes
    ----------
    centre, scale : (T, K) float64 arrays
        Mean and standard deviation of each triangle's features on unoccluded fits.
    hidden_weights : (3 K, H) float64 array
        Weights of the hidden layer (ReLU) on the standardised features ``z``, their
        squares and the neighbours' mean ``z``.
    hidden_bias : (H,) float64 array
    output_weights : (H,) float64 array
        Weights of the output (logistic) on the hidden layer.
    output_bias : float
    threshold : float
        A landmark whose triangles' mean probability is above it is occluded.
    report : dict
        How it was trained (JSON-ready).
    """

    centre: np.ndarray
    scale: np.ndarray
    hidden_weights: np.ndarray
    hidden_bias: np.ndarray
    output_weights: np.ndarray
    output_bias: float
    threshold: float
    report: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        k = len(FEATURES)
        if self.centre.shape != self.scale.shape or self.centre.shape[1:] != (k,):
            raise ValueError(f"occlusion statistics of shape {self.centre.shape} and "
                             f"{self.scale.shape}, expected (T, {k}) both")
        h = self.hidden_bias.shape
        if (self.hidden_weights.shape != (3 * k, *h) or self.output_weights.shape != h
                or not np.all(self.scale > 0)):
            raise ValueError("occlusion network weights do not fit together, or a scale is "
                             "not positive")

    @property
    def n_triangles(self) -> int:
        return len(self.centre)

    def arrays(self, prefix: str) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """The JSON header and the named arrays, for a model file."""
        names = ("centre", "scale", "hidden_weights", "hidden_bias", "output_weights")
        arrays = {f"{prefix}_{name}": getattr(self, name) for name in names}
        header = {"features": list(FEATURES), "output_bias": self.output_bias,
                  "threshold": self.threshold, "report": self.report}
        return header, arrays

    @classmethod
    def from_arrays(cls, header: dict[str, Any], arrays: dict[str, np.ndarray], prefix: str
                    ) -> OcclusionModel:
        """The model written by :meth:`arrays`."""
        if list(header["features"]) != list(FEATURES):
            raise ValueError(f"occlusion features {header['features']}, this aamtrack reads "
                             f"{list(FEATURES)}")

        def get(name: str) -> np.ndarray:
            return np.asarray(arrays[f"{prefix}_{name}"], np.float64)

        return cls(get("centre"), get("scale"), get("hidden_weights"), get("hidden_bias"),
                   get("output_weights"), float(header["output_bias"]),
                   float(header["threshold"]), dict(header.get("report", {})))


class TriangleFeatures:
    """The features of :data:`FEATURES` of each triangle of a reference frame.

    Parameters
    ----------
    aam : AAM
    """

    def __init__(self, aam: AAM) -> None:
        frame: ReferenceFrame = aam.frame
        self.frame = frame
        self.aam = aam
        m, t = frame.n_pixels, len(frame.triangles)
        counts = np.bincount(frame.pixel_triangle, minlength=t).astype(np.float64)
        self.area = counts
        mean = sparse.csr_matrix((1.0 / np.maximum(counts, 1)[frame.pixel_triangle],
                                  (frame.pixel_triangle, np.arange(m))), shape=(t, m))
        self._mean = mean.astype(np.float32)
        self._texture_mean = aam.texture.mean.astype(np.float32)
        self._texture_basis = np.ascontiguousarray(aam.texture_basis, np.float32)
        self._image = np.zeros(frame.size, np.float32)

    def triangle_means(self, values: np.ndarray) -> np.ndarray:
        """The mean (T,) over each triangle of per-pixel ``values`` (M,)."""
        return np.asarray(self._mean @ np.asarray(values, np.float32), np.float64)

    def observed(self, fit: AAMFit) -> np.ndarray:
        """The texture seen (M,) float32: the one the fit kept, or its residual plus its
        model texture (the mean over the channels of a colour model)."""
        channels = self.aam.channels
        if fit.texture is not None:
            g = np.asarray(fit.texture, np.float32)
            return g if channels == 1 else g.reshape(-1, channels).mean(axis=1)
        model = self._texture_mean + self._texture_basis @ fit.c.astype(np.float32)
        if channels > 1:
            model = model.reshape(-1, channels).mean(axis=1)
        return fit.residual + model

    def __call__(self, fit: AAMFit) -> np.ndarray:
        """Features (T, K) of ``fit``."""
        return self.of(self.observed(fit), fit.residual)

    def of(self, g: np.ndarray, r: np.ndarray) -> np.ndarray:
        """Features (T, K) of a texture seen ``g`` (M,) with residual ``r`` (M,)."""
        image = self._image
        image[self.frame.mask] = g
        gx = cv2.Sobel(image, cv2.CV_32F, 1, 0, ksize=3)
        gy = cv2.Sobel(image, cv2.CV_32F, 0, 1, ksize=3)
        mask = self.frame.mask
        grad = gx[mask] ** 2 + gy[mask] ** 2
        stacked = np.empty((len(g), 5), np.float32)
        stacked[:, 0], stacked[:, 1], stacked[:, 2] = r * r, r, g
        stacked[:, 3], stacked[:, 4] = g * g, grad
        means = np.asarray(self._mean @ stacked, np.float64)
        variance = np.maximum(means[:, 3] - means[:, 2] ** 2, 0.0)
        return np.stack([np.log(means[:, 0] + EPS), means[:, 1], np.log(variance + EPS),
                         np.log(means[:, 4] + EPS)], axis=1)


def neighbours(frame: ReferenceFrame) -> np.ndarray:
    """Averaging matrix (T, T) over each triangle's neighbours (those sharing an edge)."""
    triangles = frame.triangles
    t = len(triangles)
    edges: dict[tuple[int, int], list[int]] = {}
    for k, (a, b, c) in enumerate(triangles.tolist()):
        for edge in ((a, b), (b, c), (a, c)):
            edges.setdefault(tuple(sorted(edge)), []).append(k)
    adjacency = np.zeros((t, t))
    for owners in edges.values():
        for i in owners:
            for j in owners:
                if i != j:
                    adjacency[i, j] = 1.0
    total = adjacency.sum(axis=1, keepdims=True)
    return np.divide(adjacency, total, out=np.zeros_like(adjacency), where=total > 0)


def inputs(model: OcclusionModel, features: np.ndarray, around: np.ndarray) -> np.ndarray:
    """The network's inputs (..., T, 3 K) of features (..., T, K), ``around`` from
    :func:`neighbours`."""
    z = (features - model.centre) / model.scale
    return np.concatenate([z, z * z, around @ z], axis=-1)


def probabilities(model: OcclusionModel, features: np.ndarray, around: np.ndarray
                  ) -> np.ndarray:
    """Probability (..., T) that each triangle is covered, from its features (..., T, K)."""
    hidden = np.maximum(inputs(model, features, around) @ model.hidden_weights
                        + model.hidden_bias, 0.0)
    logit = np.clip(hidden @ model.output_weights + model.output_bias, -50.0, 50.0)
    return 1.0 / (1.0 + np.exp(-logit))


def landmark_weights(frame: ReferenceFrame, n_points: int) -> np.ndarray:
    """Weights (N, T) averaging triangle values over the triangles around each landmark, by
    area (a landmark on no triangle gets zeros)."""
    area = np.bincount(frame.pixel_triangle, minlength=len(frame.triangles)).astype(np.float64)
    weights = np.zeros((n_points, len(frame.triangles)))
    for t, corners in enumerate(frame.triangles):
        weights[corners, t] = area[t]
    total = weights.sum(axis=1, keepdims=True)
    return np.divide(weights, total, out=np.zeros_like(weights), where=total > 0)


class OcclusionTest:
    """Per-landmark occlusion flags of AAM fits.

    Parameters
    ----------
    model : OcclusionModel
    aam : AAM
        The AAM whose reference frame the model was learned in.

    Raises
    ------
    ValueError
        When the model's triangles are not the AAM's.
    """

    def __init__(self, model: OcclusionModel, aam: AAM) -> None:
        if model.n_triangles != len(aam.frame.triangles):
            raise ValueError(f"occlusion model of {model.n_triangles} triangles, the AAM's "
                             f"reference frame has {len(aam.frame.triangles)}")
        self.model = model
        self.features = TriangleFeatures(aam)
        self.weights = landmark_weights(aam.frame, aam.scheme.n_points)
        self.around = neighbours(aam.frame)

    def scores(self, fit: AAMFit) -> np.ndarray:
        """Per landmark (N,), the mean probability that its part of the face is covered."""
        return self.weights @ probabilities(self.model, self.features(fit), self.around)

    def __call__(self, fit: AAMFit) -> np.ndarray:
        """Occluded flags (N,) bool of ``fit``'s landmarks."""
        return self.scores(fit) > self.model.threshold
