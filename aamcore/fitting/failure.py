"""Deciding whether a fit has failed: the thesis's eq. 7.2 and a chi-square test."""

from __future__ import annotations

import numpy as np

FAILURE_TESTS = ("eq7.2", "chi2")


class FailureTest:
    """Decide whether a fit has failed from its appearance parameters ``c``.

    Parameters
    ----------
    variances : (t_c,) array
        Variances of the appearance parameters (combined-model eigenvalues).
    kind : {"eq7.2", "chi2"}
        ``eq7.2``: the thesis's test, any parameter beyond 3 sd. With many
        modes it flags good fits of unseen faces often (each of 84 modes
        has a 0.27 % chance, 20 % in all for Gaussian parameters).
        ``chi2``: the squared Mahalanobis distance ``sum(c_i^2 / lambda_i)``
        beyond the 99.7 % quantile of a chi-square with ``t_c`` degrees of
        freedom: the same 0.3 % false-alarm rate whatever the number of modes.
    """

    def __init__(self, variances: np.ndarray, kind: str = "eq7.2") -> None:
        if kind not in FAILURE_TESTS:
            raise ValueError(f"unknown failure test {kind!r}: choose one of {FAILURE_TESTS}")
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
