"""Deciding whether a fit has failed: the thesis's eq. 7.2, a chi-square test, a learned score.

``eq7.2`` and ``chi2`` judge the AAM appearance ``c`` (:class:`FailureTest`);
``quality`` the learned fit-quality score of the landmarks (:class:`QualityTest`),
which needs no texture warp; ``auto`` is ``quality`` for the methods that compute
no appearance (``local-binary``) and ``chi2`` for the AAM methods.
"""

from __future__ import annotations

import math

import numpy as np

from aamcore.fitting.config import FAILURE_TESTS

APPEARANCE_TESTS = ("chi2", "eq7.2")
"""The tests that judge the appearance ``c``."""


class FailureTest:
    """Decide whether a fit has failed from its appearance parameters ``c``.

    Parameters
    ----------
    variances : (t_c,) array
        Variances of the appearance parameters (combined-model eigenvalues).
    kind : {"eq7.2", "chi2", "quality"}
        ``eq7.2``: the thesis's test, any parameter beyond 3 sd. With many
        modes it flags good fits of unseen faces often (each of 84 modes
        has a 0.27 % chance, 20 % in all for Gaussian parameters).
        ``chi2``: the squared Mahalanobis distance ``sum(c_i^2 / lambda_i)``
        beyond the 99.7 % quantile of a chi-square with ``t_c`` degrees of
        freedom: the same 0.3 % false-alarm rate whatever the number of modes.
        ``quality``: ``c`` is not judged (only finite values and a shape of
        some size); the fitter applies the :class:`QualityTest`.
    """

    def __init__(self, variances: np.ndarray, kind: str = "eq7.2") -> None:
        if kind not in FAILURE_TESTS or kind == "auto":
            raise ValueError(f"unknown failure test {kind!r}: choose one of "
                             f"{[k for k in FAILURE_TESTS if k != 'auto']}")
        self.kind = kind
        self.limits = 3.0 * np.sqrt(variances)
        self.inverse_variances = 1.0 / variances
        from scipy.stats import chi2  # a slow import, kept out of start-up

        self._chi2 = chi2(len(variances))
        self.chi2_limit = float(self._chi2.ppf(0.997))

    def confidence(self, c: np.ndarray) -> float:
        """How typical the appearance ``c`` is of faces, 0 to 1.

        Twice the chi-square tail probability of its squared Mahalanobis
        distance, capped at 1: a typical face (distance near its degrees of
        freedom or less) scores near 1, one at the failure bound 0.006.
        """
        if not np.all(np.isfinite(c)):
            return 0.0
        d2 = float(np.sum(c * c * self.inverse_variances))
        return min(1.0, 2.0 * float(self._chi2.sf(d2)))

    def __call__(self, c: np.ndarray, points: np.ndarray) -> str:
        """Why the fit ``(c, points)`` has failed, or ``""``."""
        if not (np.all(np.isfinite(c)) and np.all(np.isfinite(points))):
            return "non-finite parameters"
        if np.ptp(points[:, 0]) < 4 or np.ptp(points[:, 1]) < 4:
            return "degenerate shape"
        if self.kind == "quality":
            return ""
        if self.kind == "chi2":
            d2 = float(np.sum(c * c * self.inverse_variances))
            if d2 > self.chi2_limit:
                return (
                    f"appearance Mahalanobis distance^2 {d2:.0f} beyond the 99.7 % "
                    f"chi-square bound {self.chi2_limit:.0f}"
                )
            return ""
        beyond = np.flatnonzero(np.abs(c) > self.limits)
        if beyond.size:
            return f"appearance parameter {int(beyond[0]) + 1} beyond 3 sigma (eq. 7.2)"
        return ""


class QualityTest:
    """Decide whether a fit has failed from its learned quality score.

    The score is the predicted ``log(NME)`` of the landmarks (one fern stage,
    :class:`~aamcore.fitting.algorithm.local_binary.BinaryCascade`); the
    threshold is calibrated on held-out fits (the model stores it).

    Parameters
    ----------
    threshold : float
        A score above it is a failed fit.
    """

    WIDTH = 0.17
    """Log-NME width of the confidence ramp: confidence 0.5 half a log unit under the
    threshold (the NME 0.6 times the threshold's), 0.05 at the threshold."""

    def __init__(self, threshold: float) -> None:
        if not math.isfinite(threshold):
            raise ValueError(f"quality threshold {threshold} is not finite")
        self.threshold = float(threshold)

    def reason(self, score: float) -> str:
        """Why a fit of quality ``score`` has failed, or ``""``."""
        if math.isnan(score):
            return "no quality score"
        if score > self.threshold:
            return (f"fit-quality score {score:.2f} above {self.threshold:.2f} "
                    f"(predicted NME {math.exp(min(score, 50.0)):.3f})")
        return ""

    def confidence(self, score: float) -> float:
        """How good a fit of quality ``score`` is, 0 to 1: a logistic ramp in the score,
        0.05 at the threshold and near 1 a log unit below it."""
        if not math.isfinite(score):
            return 0.0
        z = (score - self.threshold + 0.5) / self.WIDTH
        return 1.0 / (1.0 + math.exp(min(z, 700.0)))
