"""What a fit returns."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class FitResult:
    """The outcome of fitting an AAM to one image.

    Attributes
    ----------
    points : (N, 2) array
        Fitted landmarks in image pixels.
    c : (t_c,) array
        Appearance parameters.
    t : (4,) array
        Pose parameters ``(s_x, s_y, t_x, t_y)``.
    error : float
        Final texture error, mean squared normalised residual (eq. 7.7).
    iterations : int
    failed : bool
        True when the fit failed the test of eq. 7.2 (an appearance parameter
        beyond 3 sigma) or another check named in ``reason``.
    reason : str
        Why the fit failed, empty otherwise.
    iteration_seconds : list of float
        Time each iteration took.
    errors : list of float
        Texture error after each iteration.
    """

    points: np.ndarray
    c: np.ndarray
    t: np.ndarray
    error: float
    iterations: int
    failed: bool = False
    reason: str = ""
    iteration_seconds: list[float] = field(default_factory=list)
    errors: list[float] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.failed


def failure_reason(c: np.ndarray, limits: np.ndarray, points: np.ndarray) -> str:
    """Why a fit has failed, or ``""``: eq. 7.2 plus non-finite or collapsed shapes."""
    if not (np.all(np.isfinite(c)) and np.all(np.isfinite(points))):
        return "non-finite parameters"
    if np.ptp(points[:, 0]) < 4 or np.ptp(points[:, 1]) < 4:
        return "degenerate shape"
    beyond = np.flatnonzero(np.abs(c) > limits)
    if beyond.size:
        return f"appearance parameter {int(beyond[0]) + 1} beyond 3 sigma (eq. 7.2)"
    return ""
