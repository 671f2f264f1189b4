"""Damped Gauss-Newton with a fixed, pre-learned update matrix (Algorithm 7, eq. 7.1)."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

from aamcore.fitting.algorithm.base import AlgorithmSettings, ModelAlgorithm
from aamcore.fitting.result import AAMFit, LandmarkFit
from aamcore.fitting.update_matrix import UpdateMatrix
from aamcore.model.aam import AAM
from aamcore.model.similarity import Similarity

if TYPE_CHECKING:
    from aamcore.fitting.model import FittingModel

DAMPING = (1.0, 1.5, 0.5, 0.25, 0.125)
"""Step sizes: the full step first, then the alternatives of Algorithm 7."""
MAX_ITERATIONS = 20


class FixedJacobian(ModelAlgorithm):
    """Fit ``p = (c, t)`` by ``p <- p - alpha R r`` with the learned ``R``.

    Parameters
    ----------
    aam : AAM
    update : UpdateMatrix
        ``R`` from :func:`aamcore.fitting.training.update.train_update`.
    settings : AlgorithmSettings, optional
        At most ``settings.max_iterations`` iterations (:data:`MAX_ITERATIONS` by default).
    """

    name = "fixed-jacobian"

    def __init__(
        self, aam: AAM, update: UpdateMatrix, settings: AlgorithmSettings | None = None
    ) -> None:
        super().__init__(aam, settings)
        self.R = np.ascontiguousarray(update.R, dtype=np.float32)
        self.max_iterations = (settings and settings.max_iterations) or MAX_ITERATIONS
        self.n_c = aam.n_appearance

    @classmethod
    def from_model(
        cls, model: FittingModel, settings: AlgorithmSettings, level: int = 0
    ) -> FixedJacobian:
        """The fitter of the update matrix learned for pyramid ``level``."""
        return cls(model.aam, model.update(level), settings)

    def _step(
        self, c: np.ndarray, t: np.ndarray, dp: np.ndarray, alpha: float
    ) -> tuple[np.ndarray, np.ndarray]:
        c_new = c - alpha * dp[: self.n_c]
        # The update predicts how the current pose is displaced from the
        # truth in the model frame (T = T_true o T_d): undo it by composition.
        undo = Similarity.from_params(alpha * dp[self.n_c :]).inverse()
        return c_new, (Similarity.from_params(t) @ undo).params

    def track(self, image: np.ndarray, previous: LandmarkFit) -> AAMFit:
        """Fit from the previous frame's parameters (its shape's, for a fit without an
        appearance)."""
        if isinstance(previous, AAMFit) and previous.c.size == self.n_c:
            return self.run(image, previous.c, previous.similarity)
        return self.run_from_shape(image, previous.points)

    def run_from_shape(self, image: np.ndarray, shape: np.ndarray) -> AAMFit:
        """Fit from landmarks ``shape`` (N, 2): their shape parameters, the mean texture."""
        b, sim = self.aam.shape.fit_points(shape, iterations=2)
        c0 = self.aam.combined.params(b, np.zeros(self.aam.texture.n_modes))
        return self.run(image, c0, sim)

    def run(self, image: np.ndarray, c0: np.ndarray, start: Similarity) -> AAMFit:
        """Fit from ``(c0, start)`` on a prepared ``image``."""
        c, t = c0.astype(np.float64).copy(), start.params
        r, error = self.residual(image, c, t)
        errors, seconds = [error], []
        iterations, converged = 0, False
        for _ in range(self.max_iterations):
            begun = time.perf_counter()
            dp = (self.R @ r).astype(np.float64)
            improved = False
            for alpha in DAMPING:
                c_new, t_new = self._step(c, t, dp, alpha)
                r_new, e_new = self.residual(image, c_new, t_new)
                if e_new < error:
                    c, t, r, error = c_new, t_new, r_new, e_new
                    improved = True
                    break
            iterations += 1
            seconds.append(time.perf_counter() - begun)
            errors.append(error)
            if not improved:
                converged = True
                break
        return self.result(self.residual.shape(c, t), c, Similarity.from_params(t), r,
                           iterations=iterations, converged=converged, errors=errors,
                           seconds=seconds)
