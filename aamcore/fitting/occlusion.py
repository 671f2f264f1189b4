"""Which landmarks are covered: read from the texture and residual around each.

The appearance of a fit (:class:`~aamcore.fitting.appearance.AppearanceSampler`)
leaves the normalised texture ``g`` seen in the reference frame and its
residual ``r = g - g_model(c)``. Where something covers the face, the texture
there is not a face's: a patterned occluder leaves a residual the model cannot
explain, and a smooth one (a hand) takes away the contrast a face has at the
eyes, brows, nose and lips, which the residual alone, small over a flat patch,
does not show. So around each landmark, over two discs of its part of the face
(:data:`SCALES` times :data:`PART_RADIUS` face widths, the part the benches'
truth uses), four numbers are read in the sampler's pass: the log energy of the
residual, its mean, and the log variance and log gradient energy of the texture
(:class:`Discs`); with the fit's log texture error, they are standardised by
what that landmark shows on unoccluded faces, and a small network learned on
faces with drawn occluders (:mod:`aamcore.fitting.training.occlusion`) turns
them, with the neighbouring landmarks' mean, into the probability that the
landmark's part of the face is covered; above the learned threshold it is
flagged. A landmark outside the image is flagged whatever its texture says.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np
from scipy import sparse

from aamcore.model.aam import AAM
from aamcore.warp.box import BoxWarp
from aamcore.warp.reference_frame import ReferenceFrame

FEATURES = ("log_residual_energy", "mean_residual", "log_variance", "log_gradient_energy",
            "model_correlation", "mean_correlation")
"""What is read over each disc of a landmark, in this order."""
SCALES = (1.0, 2.0)
"""Radii of the discs read around each landmark, in :data:`PART_RADIUS` units."""
PART_RADIUS = 0.08
"""A landmark's part of the face: a disc of this many face widths (the frame's width)."""
N_FEATURES = len(FEATURES) * len(SCALES) + 1
"""Features per landmark: each disc's, then the fit's log texture error."""
EPS = 1e-4
"""Added before the logarithms (normalised texture units squared)."""
Z_LIMIT = 6.0
"""Standardised features are clipped to +-this: beyond it a feature says no more (and a
feature that barely varies on clean faces would otherwise swamp the others)."""


def feature_names() -> list[str]:
    """The name of every feature column, as the model file records them."""
    return [f"{name}@{scale:g}" for scale in SCALES for name in FEATURES] + ["log_error"]


@dataclass(frozen=True)
class OcclusionModel:
    """What the occlusion test learned (a part of the fitting model file): two small networks.

    The first reads each landmark's own features; the second, the first's logits of every
    landmark of the face at once, so that a landmark is judged with what covers its
    neighbours (an occluder is one shape over several landmarks).

    Attributes
    ----------
    centre, scale : (N, F) float64 arrays
        Mean and standard deviation of each landmark's features on unoccluded fits
        (``F`` = :data:`N_FEATURES`).
    hidden_weights : (3 F, H) float64 array
        Weights of the first network's hidden layer (ReLU) on the standardised features
        ``z``, their squares and the neighbouring landmarks' mean ``z``.
    hidden_bias : (H,) float64 array
    output_weights : (H,) float64 array
        Weights of its output (a logit per landmark).
    output_bias : float
    context_weights : (N, G) float64 array
        Weights of the second network's hidden layer (ReLU) on the N logits.
    context_bias : (G,) float64 array
    context_output : (G, N) float64 array
        Weights of its output (logistic, one per landmark).
    context_output_bias : (N,) float64 array
    threshold : float
        A landmark whose probability is above it is occluded.
    report : dict
        How it was trained and how it did (JSON-ready).
    """

    centre: np.ndarray
    scale: np.ndarray
    hidden_weights: np.ndarray
    hidden_bias: np.ndarray
    output_weights: np.ndarray
    output_bias: float
    context_weights: np.ndarray
    context_bias: np.ndarray
    context_output: np.ndarray
    context_output_bias: np.ndarray
    threshold: float
    report: dict[str, Any] = field(default_factory=dict)

    ARRAYS = ("centre", "scale", "hidden_weights", "hidden_bias", "output_weights",
              "context_weights", "context_bias", "context_output", "context_output_bias")

    def __post_init__(self) -> None:
        f, n = N_FEATURES, len(self.centre)
        if self.centre.shape != self.scale.shape or self.centre.shape[1:] != (f,):
            raise ValueError(f"occlusion statistics of shape {self.centre.shape} and "
                             f"{self.scale.shape}, expected (N, {f}) both")
        h, g = self.hidden_bias.shape, self.context_bias.shape
        if (self.hidden_weights.shape != (3 * f, *h) or self.output_weights.shape != h
                or self.context_weights.shape != (n, *g)
                or self.context_output.shape != (*g, n)
                or self.context_output_bias.shape != (n,) or not np.all(self.scale > 0)):
            raise ValueError("occlusion network weights do not fit together, or a scale is "
                             "not positive")

    @property
    def n_points(self) -> int:
        return len(self.centre)

    def arrays(self, prefix: str) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """The JSON header and the named arrays, for a model file."""
        arrays = {f"{prefix}_{name}": getattr(self, name) for name in self.ARRAYS}
        header = {"features": feature_names(), "output_bias": self.output_bias,
                  "threshold": self.threshold, "report": self.report}
        return header, arrays

    @classmethod
    def from_arrays(cls, header: dict[str, Any], arrays: dict[str, np.ndarray], prefix: str
                    ) -> OcclusionModel:
        """The model written by :meth:`arrays`."""
        if list(header["features"]) != feature_names():
            raise ValueError(f"occlusion features {header['features']}, this aamtrack reads "
                             f"{feature_names()}: retrain the model")
        got = {name: np.asarray(arrays[f"{prefix}_{name}"], np.float64) for name in cls.ARRAYS}
        return cls(**got, output_bias=float(header["output_bias"]),
                   threshold=float(header["threshold"]), report=dict(header.get("report", {})))


class Discs:
    """The features of :data:`FEATURES` over the discs around each landmark of a frame.

    Parameters
    ----------
    box : BoxWarp
        The frame's box the texture is sampled on.
    n_points : int
    mean : (M,) array
        The model's mean texture (one value per pixel).

    Notes
    -----
    The residual, its correlations and the mean texture are read over the disc's pixels
    inside the face; the variance and the gradient over all the box's pixels of the disc
    (past the outline too: the edge of the jaw against the background is part of what a
    hand over the jaw hides). Two sparse products give every disc's means.
    """

    def __init__(self, box: BoxWarp, n_points: int, mean: np.ndarray) -> None:
        frame = box.frame
        self.box = box
        self.n_points = n_points
        vertices = frame.vertices[:n_points]
        face = float(np.ptp(frame.vertices[:, 0]))
        box_h, box_w = box.size
        ys, xs = np.mgrid[0:box_h, 0:box_w]
        everywhere = np.stack([xs.ravel(), ys.ravel()], axis=1) - box.origin
        radii = [max(scale * PART_RADIUS * face, 1.5) for scale in SCALES]
        self.inner = _disc_means(frame.pixels, vertices, radii)
        self.outer = _disc_means(everywhere, vertices, radii)
        self.inside = box.inside
        self._inner = np.empty((frame.n_pixels, 6), np.float32)
        self._outer = np.empty((box_h * box_w, 3), np.float32)
        self.mean = np.asarray(mean, np.float32)
        t = self.mean.astype(np.float64)
        self._t, self._t2 = self.inner @ t, self.inner @ (t * t)

    @classmethod
    def of(cls, aam: AAM, box: BoxWarp) -> Discs:
        """The discs of ``aam``'s landmarks on ``box``, with its mean texture (the mean over
        the channels of a colour model)."""
        mean = aam.texture.mean.reshape(aam.frame.n_pixels, -1).mean(axis=1)
        return cls(box, aam.scheme.n_points, mean)

    def __call__(self, seen: np.ndarray, g: np.ndarray, r: np.ndarray, error: float
                 ) -> np.ndarray:
        """Features (N, :data:`N_FEATURES`): ``seen`` (H, W) float32 is the box normalised
        as the texture, ``g`` (M,) the texture inside the face, ``r`` (M,) its residual,
        ``error`` the mean squared residual."""
        gx = cv2.Sobel(seen, cv2.CV_32F, 1, 0, ksize=3)
        gy = cv2.Sobel(seen, cv2.CV_32F, 0, 1, ksize=3)
        outer = self._outer
        outer[:, 0] = seen.ravel()
        np.multiply(outer[:, 0], outer[:, 0], out=outer[:, 1])
        np.add(np.square(gx).ravel(), np.square(gy).ravel(), out=outer[:, 2])
        inner = self._inner
        np.multiply(r, r, out=inner[:, 0])
        inner[:, 1] = r
        inner[:, 2] = g
        np.multiply(g, g, out=inner[:, 3])
        np.multiply(g, r, out=inner[:, 4])
        np.multiply(g, self.mean, out=inner[:, 5])
        rr, r1, g1, gg, gr, gt = (self.inner @ inner).astype(np.float64).T
        b1, bb, grad = (self.outer @ outer).astype(np.float64).T
        var_g = np.maximum(gg - g1 * g1, 0.0)
        m1 = g1 - r1  # the model texture m = g - r
        cov_gm = gg - gr - g1 * m1
        var_m = np.maximum(gg - 2 * gr + rr - m1 * m1, 0.0)
        var_t = np.maximum(self._t2 - self._t * self._t, 0.0)
        columns = (np.log(rr + EPS), r1, np.log(np.maximum(bb - b1 * b1, 0.0) + EPS),
                   np.log(grad + EPS), cov_gm / np.sqrt(var_g * var_m + 1e-6),
                   (gt - g1 * self._t) / np.sqrt(var_g * var_t + 1e-6))
        n, k = self.n_points, len(FEATURES)
        out = np.empty((n, N_FEATURES))
        for j, column in enumerate(columns):
            for d in range(len(SCALES)):
                out[:, d * k + j] = column[d * n:(d + 1) * n]
        out[:, -1] = np.log(error + EPS)
        return out


def _disc_means(pixels: np.ndarray, centres: np.ndarray, radii: list[float]
                ) -> sparse.csr_matrix:
    """Averaging matrix (S N, P) float32 over the ``pixels`` (P, 2) within each radius of
    each centre (N, 2) (the nearest pixel for a disc holding none); the discs but the first
    read one pixel in four (the even rows and columns): their means are as good, at a
    quarter of the cost."""
    rows, cols, vals = [], [], []
    n = len(centres)
    even = np.all(np.round(pixels).astype(np.int64) % 2 == 0, axis=1)
    for s, radius in enumerate(radii):
        for k, centre in enumerate(centres):
            d2 = np.sum((pixels - centre) ** 2, axis=1)
            inside = np.flatnonzero((d2 <= radius * radius) & (even | (s == 0)))
            if inside.size == 0:
                inside = np.array([int(np.argmin(d2))])
            rows.append(np.full(inside.size, s * n + k))
            cols.append(inside)
            vals.append(np.full(inside.size, 1.0 / inside.size))
    return sparse.csr_matrix((np.concatenate(vals).astype(np.float32),
                              (np.concatenate(rows), np.concatenate(cols))),
                             shape=(len(radii) * n, len(pixels)))


def box_of(aam: AAM) -> BoxWarp:
    """The box the appearance samples: the frame grown by the largest disc's radius."""
    face = float(np.ptp(aam.frame.vertices[:, 0]))
    margin = int(np.ceil(max(SCALES) * PART_RADIUS * face)) + 1
    return BoxWarp(aam.frame, aam.scheme.n_points, margin)


def neighbours(frame: ReferenceFrame, n_points: int) -> np.ndarray:
    """Averaging matrix (N, N) over each landmark's neighbours (those it shares a triangle
    edge with in the frame)."""
    adjacency = np.zeros((n_points, n_points))
    for a, b, c in frame.triangles.tolist():
        for i, j in ((a, b), (b, c), (a, c)):
            if i < n_points and j < n_points:
                adjacency[i, j] = adjacency[j, i] = 1.0
    total = adjacency.sum(axis=1, keepdims=True)
    return np.divide(adjacency, total, out=np.zeros_like(adjacency), where=total > 0)


def inputs(model: OcclusionModel, features: np.ndarray, around: np.ndarray) -> np.ndarray:
    """The network's inputs (..., N, 3 F) of features (..., N, F), ``around`` from
    :func:`neighbours`."""
    z = np.clip((features - model.centre) / model.scale, -Z_LIMIT, Z_LIMIT)
    return np.concatenate([z, z * z, around @ z], axis=-1)


OUTSIDE_LOGIT = 8.0
"""The first network's logit of a landmark outside the image (covered, whatever its texture
says), as the second network reads it."""


def logits(model: OcclusionModel, features: np.ndarray, around: np.ndarray,
           outside: np.ndarray | None = None) -> np.ndarray:
    """The first network's logit (..., N) that each landmark is covered, from its features
    (..., N, F); :data:`OUTSIDE_LOGIT` for the landmarks ``outside`` (..., N) the image."""
    hidden = np.maximum(inputs(model, features, around) @ model.hidden_weights
                        + model.hidden_bias, 0.0)
    out = np.clip(hidden @ model.output_weights + model.output_bias, -20.0, 20.0)
    return out if outside is None else np.where(outside, OUTSIDE_LOGIT, out)


def probabilities(model: OcclusionModel, features: np.ndarray, around: np.ndarray,
                  outside: np.ndarray | None = None) -> np.ndarray:
    """Probability (..., N) that each landmark's part of the face is covered, from the
    features (..., N, F) of all the face's landmarks."""
    first = logits(model, features, around, outside)
    hidden = np.maximum(first @ model.context_weights + model.context_bias, 0.0)
    logit = np.clip(hidden @ model.context_output + model.context_output_bias, -50.0, 50.0)
    return 1.0 / (1.0 + np.exp(-logit))


class OcclusionTest:
    """Per-landmark occlusion flags from the features of :class:`Discs`.

    Parameters
    ----------
    model : OcclusionModel
    aam : AAM
        The AAM whose reference frame the model was learned in.

    Raises
    ------
    ValueError
        When the model's landmarks are not the AAM's.
    """

    def __init__(self, model: OcclusionModel, aam: AAM) -> None:
        n_points = aam.scheme.n_points
        if model.n_points != n_points:
            raise ValueError(f"occlusion model of {model.n_points} landmarks, the AAM has "
                             f"{n_points}")
        self.model = model
        self.discs = Discs.of(aam, box_of(aam))
        self.around = neighbours(aam.frame, n_points)

    def scores(self, features: np.ndarray, outside: np.ndarray | None = None) -> np.ndarray:
        """Per landmark (N,), the probability that its part of the face is covered, from a
        fit's features (N, F) and its landmarks ``outside`` (N,) the image."""
        return probabilities(self.model, features, self.around, outside)

    def __call__(self, features: np.ndarray, outside: np.ndarray) -> np.ndarray:
        """Occluded flags (N,) bool: the landmarks ``outside`` (N,) the image and those
        whose score is above the threshold."""
        return (self.scores(features, outside) > self.model.threshold) | outside
