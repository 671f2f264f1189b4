"""Damped Gauss-Newton with a fixed, pre-learned update matrix (Algorithm 7, eq. 7.1)."""

from __future__ import annotations

import time

import numpy as np

from aamcore.fitting.residuals import ResidualFunction, WarpFn
from aamcore.fitting.result import FailureTest, FitResult
from aamcore.fitting.training.update import UpdateMatrix
from aamcore.model.aam import AAM
from aamcore.model.similarity import compose_poses, invert_pose

# Step sizes: the full step first, then the alternatives of Algorithm 7.
DAMPING = (1.0, 1.5, 0.5, 0.25, 0.125)


class FixedJacobian:
    """Fit ``p = (c, t)`` by ``p <- p - alpha R r`` with the learned ``R``.

    Parameters
    ----------
    aam : AAM
    update : UpdateMatrix
        ``R`` from :func:`aamcore.fitting.training.update.train_update`.
    max_iterations : int
    warp : callable, optional
        Texture sampler ``warp(image, shape) -> (M, C)`` (CPU warp by default).
    failure : FailureTest, optional
        The test of a failed fit (eq. 7.2 by default).
    """

    name = "fixed-jacobian"

    def __init__(
        self,
        aam: AAM,
        update: UpdateMatrix,
        max_iterations: int = 20,
        warp: WarpFn | None = None,
        failure: FailureTest | None = None,
    ) -> None:
        self.aam = aam
        self.R = np.ascontiguousarray(update.R, dtype=np.float32)
        self.max_iterations = max_iterations
        self.residual = ResidualFunction(aam, warp)
        self.n_c = aam.n_appearance
        self.failure = failure or FailureTest(aam.combined.pca.variances)

    def _step(self, c: np.ndarray, t: np.ndarray, dp: np.ndarray, alpha: float):
        c_new = c - alpha * dp[: self.n_c]
        # The update predicts how the current pose is displaced from the
        # truth in the model frame (T = T_true o T_d): undo it by composition.
        t_new = compose_poses(t, invert_pose(alpha * dp[self.n_c :]))
        return c_new, t_new

    def track(self, image: np.ndarray, previous: FitResult) -> FitResult:
        """Fit from the previous frame's parameters."""
        return self.run(image, previous.c, previous.t)

    def run(self, image: np.ndarray, c0: np.ndarray, t0: np.ndarray) -> FitResult:
        """Fit from ``(c0, t0)`` on a prepared ``image``."""
        c, t = c0.astype(np.float64).copy(), t0.astype(np.float64).copy()
        r, error = self.residual(image, c, t)
        errors, seconds = [error], []
        iterations = 0
        for _ in range(self.max_iterations):
            start = time.perf_counter()
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
            seconds.append(time.perf_counter() - start)
            errors.append(error)
            if not improved:
                break
        points = self.residual.shape(c, t)
        reason = self.failure(c, points)
        return FitResult(points, c, t, error, iterations, bool(reason), reason, seconds, errors)
