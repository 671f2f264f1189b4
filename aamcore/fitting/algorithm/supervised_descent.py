"""Cascaded regression in the AAM's shape space (parametric supervised descent).

Beyond the thesis: where Algorithm 5 learns one linear update from small,
one-parameter-at-a-time perturbations of the texture residual, this learns a
short cascade of linear updates (Xiong & De la Torre 2013, in the parametric
form of menpofit's supervised descent) from starts drawn like the real ones
(the Haar box through the learned mapping, plus random similarity noise of
the size the mapping leaves), on HOG features of the shape-normalised face.
Each stage maps features sampled at the current shape to a step ``dq`` in the
orthonormal basis of similarity directions and shape modes used by
:mod:`~aamcore.fitting.algorithm.project_out_ic`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from aamcore.fitting.algorithm.project_out_ic import shape_basis
from aamcore.fitting.features import FrameHog
from aamcore.fitting.residuals import ResidualFunction, WarpFn
from aamcore.fitting.result import FailureTest, FitResult
from aamcore.model.aam import AAM
from aamcore.model.similarity import apply_pose, invert_pose


@dataclass(frozen=True)
class DescentCascade:
    """The learned stages.

    Attributes
    ----------
    weights : list of (D + 1, Q) float32 arrays
        One regression per stage, the last row the bias.
    hog_cell : int
        HOG cell size used for the features.
    """

    weights: list[np.ndarray]
    hog_cell: int


def model_frame_step(
    basis: np.ndarray, shape: np.ndarray, target: np.ndarray, t: np.ndarray
) -> np.ndarray:
    """Coordinates (Q,) in ``basis`` of the move from ``shape`` to ``target`` in the model frame.

    Both shapes are (N, 2) image points; ``t`` is the pose of ``shape``.
    """
    inverse = invert_pose(t)
    delta = apply_pose(inverse, target) - apply_pose(inverse, shape)
    return basis.T @ delta.ravel()


class SupervisedDescent:
    """Fit by a cascade of learned linear updates on HOG features.

    Parameters
    ----------
    aam : AAM
    cascade : DescentCascade
    warp : callable, optional
        Texture sampler ``warp(image, shape) -> (M,)`` for grey images.
    failure : FailureTest, optional
        The test of a failed fit (eq. 7.2 by default).
    """

    name = "supervised-descent"

    def __init__(
        self,
        aam: AAM,
        cascade: DescentCascade,
        warp: WarpFn | None = None,
        failure: FailureTest | None = None,
    ) -> None:
        self.aam = aam
        self.cascade = cascade
        self.residual = ResidualFunction(aam, warp)
        self.failure = failure or FailureTest(aam.combined.pca.variances)
        self.features = FrameHog(aam.frame, cascade.hog_cell)
        self.basis = shape_basis(aam.shape.mean_shape, aam.shape.pca.components)
        self.weights = [np.ascontiguousarray(w, dtype=np.float32) for w in cascade.weights]
        self.texture_mean = aam.texture.mean.astype(np.float32)
        self.texture_components = np.ascontiguousarray(aam.texture.pca.components, np.float32)

    def features_at(self, image: np.ndarray, shape: np.ndarray) -> np.ndarray:
        """Feature vector (D + 1,) with a trailing 1 for the bias."""
        texture = self.residual.warp(image, shape)
        if texture.ndim == 2:
            texture = texture.mean(axis=1)
        return np.append(self.features(texture), np.float32(1.0))

    def step(self, image: np.ndarray, shape: np.ndarray, t: np.ndarray, stage: int) -> np.ndarray:
        """Shape (N, 2) after one stage from ``shape`` whose pose is ``t``."""
        dq = self.features_at(image, shape) @ self.weights[stage]
        model = apply_pose(invert_pose(t), shape) + (self.basis @ dq).reshape(-1, 2)
        return apply_pose(t, model)

    def track(self, image: np.ndarray, previous: FitResult) -> FitResult:
        """Fit from the pose of the previous frame's fit.

        The mean shape placed where the previous landmarks were is the kind
        of start the cascade learned from; starting from the previous
        landmarks themselves would let each frame's small bias accumulate.
        """
        _, t = self.aam.shape.fit_points(previous.points, iterations=1)
        return self.run(image, np.zeros(self.aam.n_appearance), t)

    def run(self, image: np.ndarray, c0: np.ndarray, t0: np.ndarray) -> FitResult:
        """Fit from the shape of ``(c0, t0)`` on a prepared ``image``."""
        shape_model = self.aam.shape
        shape = self.residual.shape(c0, t0)
        if np.any(c0):
            b, t = shape_model.fit_points(shape, iterations=2)
        else:  # the mean shape placed by t0: nothing to fit
            b, t = np.zeros(shape_model.n_modes), np.asarray(t0, dtype=np.float64)
        seconds = []
        for stage in range(len(self.weights)):
            start = time.perf_counter()
            target = self.step(image, shape, t, stage)
            if not np.all(np.isfinite(target)):
                break
            b, t = shape_model.fit_points(target, iterations=2)
            shape = apply_pose(t, shape_model.instance(b))
            seconds.append(time.perf_counter() - start)
        g = self.residual.image_texture(image, shape)
        centred = g - self.texture_mean
        b_g = centred @ self.texture_components
        c = self.aam.combined.params(b, b_g.astype(np.float64))
        # The texture model's residual: its components are orthonormal.
        error = max(float(centred @ centred - b_g @ b_g), 0.0) / g.size
        reason = self.failure(c, shape)
        return FitResult(shape, c, t, error, len(seconds), bool(reason), reason, seconds, [error])
