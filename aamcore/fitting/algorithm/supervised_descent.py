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
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from aamcore.fitting.algorithm.base import AlgorithmSettings, ModelAlgorithm
from aamcore.fitting.algorithm.project_out_ic import shape_basis
from aamcore.fitting.features import FrameHog
from aamcore.fitting.learned import DescentCascade
from aamcore.fitting.result import AAMFit, LandmarkFit
from aamcore.model.aam import AAM
from aamcore.model.similarity import Similarity

if TYPE_CHECKING:
    from aamcore.fitting.model import FittingModel


def model_frame_step(
    basis: np.ndarray, shape: np.ndarray, target: np.ndarray, similarity: Similarity
) -> np.ndarray:
    """Coordinates (Q,) in ``basis`` of the move from ``shape`` to ``target`` in the model frame.

    Both shapes are (N, 2) image points; ``similarity`` places ``shape``'s model frame.
    """
    inverse = similarity.inverse()
    delta = inverse.apply(target) - inverse.apply(shape)
    return basis.T @ delta.ravel()


class SupervisedDescent(ModelAlgorithm):
    """Fit by a cascade of learned linear updates on HOG features.

    Parameters
    ----------
    aam : AAM
    cascade : DescentCascade
    settings : AlgorithmSettings, optional
    """

    name = "supervised-descent"

    def __init__(
        self, aam: AAM, cascade: DescentCascade, settings: AlgorithmSettings | None = None
    ) -> None:
        super().__init__(aam, settings)
        self.cascade = cascade
        self.features = FrameHog(aam.frame, cascade.hog_cell)
        self.basis = shape_basis(aam.shape.mean_shape, aam.shape.pca.components)
        self.weights = [np.ascontiguousarray(w, dtype=np.float32) for w in cascade.weights]
        self.texture_mean = aam.texture.mean.astype(np.float32)
        self.texture_components = np.ascontiguousarray(aam.texture.pca.components, np.float32)

    @classmethod
    def from_model(cls, model: FittingModel, settings: AlgorithmSettings) -> SupervisedDescent:
        """The cascade ``model`` learned."""
        if model.cascade is None:
            raise ValueError("this model has no supervised-descent cascade: train it with `--fit`")
        return cls(model.aam, model.cascade, settings)

    def features_at(self, image: np.ndarray, shape: np.ndarray) -> np.ndarray:
        """Feature vector (D + 1,) with a trailing 1 for the bias."""
        texture = self.residual.warp(image, shape)
        if texture.ndim == 2:
            texture = texture.mean(axis=1)
        return np.append(self.features(texture), np.float32(1.0))

    def step(
        self, image: np.ndarray, shape: np.ndarray, similarity: Similarity, stage: int
    ) -> np.ndarray:
        """Shape (N, 2) after one stage from ``shape`` whose model frame ``similarity`` places."""
        dq = self.features_at(image, shape) @ self.weights[stage]
        model = similarity.inverse().apply(shape) + (self.basis @ dq).reshape(-1, 2)
        return similarity.apply(model)

    def track(self, image: np.ndarray, previous: LandmarkFit) -> AAMFit:
        """Fit from the pose of the previous frame's fit.

        The mean shape placed where the previous landmarks were is the kind
        of start the cascade learned from; starting from the previous
        landmarks themselves would let each frame's small bias accumulate.
        """
        _, sim = self.aam.shape.fit_points(previous.points, iterations=1)
        return self.run(image, np.zeros(self.aam.n_appearance), sim)

    def run(self, image: np.ndarray, c0: np.ndarray, start: Similarity) -> AAMFit:
        """Fit from the shape of ``(c0, start)`` on a prepared ``image``."""
        shape_model = self.aam.shape
        shape = self.residual.shape(c0, start.params)
        if np.any(c0):
            b, sim = shape_model.fit_points(shape, iterations=2)
        else:  # the mean shape placed by the start: nothing to fit
            b, sim = np.zeros(shape_model.n_modes), start
        return self._descend(image, shape, b, sim, 0)

    def refine(self, image: np.ndarray, points: np.ndarray, stages: int) -> AAMFit:
        """The last ``stages`` stages of the cascade from landmarks ``points`` (N, 2) on a
        prepared ``image`` (the fine stages, for landmarks already near the face's)."""
        b, sim = self.aam.shape.fit_points(points, iterations=2)
        shape = sim.apply(self.aam.shape.instance(b))
        return self._descend(image, shape, b, sim, max(len(self.weights) - stages, 0))

    def _descend(self, image: np.ndarray, shape: np.ndarray, b: np.ndarray, sim: Similarity,
                 first: int) -> AAMFit:
        """The stages from ``first`` on, from ``shape`` (shape parameters ``b`` placed by
        ``sim``), then the appearance at the shape reached."""
        shape_model = self.aam.shape
        seconds = []
        for stage in range(first, len(self.weights)):
            begun = time.perf_counter()
            target = self.step(image, shape, sim, stage)
            if not np.all(np.isfinite(target)):
                break
            b, sim = shape_model.fit_points(target, iterations=2)
            shape = sim.apply(shape_model.instance(b))
            seconds.append(time.perf_counter() - begun)
        g = self.residual.image_texture(image, shape)
        b_g = (g - self.texture_mean) @ self.texture_components
        c = self.aam.combined.params(b, b_g.astype(np.float64))
        fit = self.result(shape, c, sim, g - self.residual.model_texture(c),
                          iterations=len(seconds), seconds=seconds)
        return replace(fit, errors=[fit.error])
