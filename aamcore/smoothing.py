"""Temporal smoothing of landmarks and head pose: the One Euro filter.

Casiez, Roussel and Vogel (2012), "1 Euro Filter: A Simple Speed-based Low-pass
Filter for Noisy Input in Interactive Systems": an exponential low-pass
filter whose cut-off rises with the speed of the signal, so a still face
stops jittering while a moving one is followed with little lag. Here the
speed is measured in face sizes per second (:class:`LandmarkSmoother`), so
the same settings suit a face of any size (the head pose's smoother,
:class:`aamcore.pose.smoothing.PoseSmoother`, is built on the same filter).

Every smoother starts afresh after :meth:`reset` (a lost face) or when time
goes backwards or jumps (a cut, a new stream).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np

F = TypeVar("F", bound=Any)
"""A fit: a dataclass with ``points`` (N, 2) and ``ok``."""
MAX_GAP_S = 0.5
"""Seconds between two samples after which a smoother starts afresh."""


def _alpha(cutoff_hz: np.ndarray | float, dt: float) -> np.ndarray | float:
    """Smoothing factor of an exponential filter with this cut-off at step ``dt`` (eq. 2)."""
    if isinstance(cutoff_hz, float):
        return 1.0 / (1.0 + 1.0 / (2.0 * math.pi * cutoff_hz * dt))
    tau = 1.0 / (2.0 * math.pi * np.asarray(cutoff_hz))
    return 1.0 / (1.0 + tau / dt)


@dataclass(frozen=True)
class OneEuroSettings:
    """The filter's three parameters.

    Attributes
    ----------
    min_cutoff : float
        Cut-off in Hz at rest: lower is smoother and laggier.
    beta : float
        How fast the cut-off rises with speed (per unit of speed).
    d_cutoff : float
        Cut-off in Hz of the speed estimate.
    """

    min_cutoff: float = 1.0
    beta: float = 1.0
    d_cutoff: float = 1.0


class OneEuroFilter:
    """A One Euro filter of arrays of any shape, element by element.

    Parameters
    ----------
    settings : OneEuroSettings
    """

    def __init__(self, settings: OneEuroSettings = OneEuroSettings()) -> None:
        self.settings = settings
        self._x: np.ndarray | None = None
        self._dx: np.ndarray | None = None
        self._t = 0.0

    def reset(self) -> None:
        """Forget the past: the next sample passes unchanged."""
        self._x = self._dx = None

    def __call__(self, x: np.ndarray, t: float, speed_scale: float | np.ndarray = 1.0
                 ) -> np.ndarray:
        """The filtered value of sample ``x`` at time ``t`` (seconds).

        ``speed_scale`` divides the speed before it raises the cut-off (the
        face size, for landmarks in pixels; an array: each value's own).
        """
        x = np.asarray(x, dtype=np.float64)
        dt = t - self._t
        if self._x is None or self._x.shape != x.shape or not 0 < dt <= MAX_GAP_S:
            self._x, self._dx, self._t = x.copy(), np.zeros_like(x), t
            return x.copy()
        s = self.settings
        dx = (x - self._x) / dt
        self._dx = self._dx + _alpha(s.d_cutoff, dt) * (dx - self._dx)
        cutoff = s.min_cutoff + s.beta * np.abs(self._dx) / speed_scale
        self._x = self._x + _alpha(cutoff, dt) * (x - self._x)
        self._t = t
        return self._x.copy()


LANDMARKS = OneEuroSettings(min_cutoff=0.5, beta=60.0, d_cutoff=3.0)
"""Landmark settings: speed in face sizes per second. Chosen on ``bench/bench_smoothing.py``
with the tracker that averages a tracked and a restarted fit (recipe fitting v12): a still
face's jitter -58 %, a face moving 12-15 px a frame within 2.7 % of the unsmoothed NME
(beta 40: -65 % and up to +4.7 %, beta 80: -53 % and +2.0 %; beta 4 with a 1 Hz speed
filter lagged: +50 to +73 %)."""
POSE = OneEuroSettings(min_cutoff=0.5, beta=40.0, d_cutoff=3.0)
"""Pose settings: rotation entries per second, translation in head sizes per second."""
HEAD_SIZE_MM = 150.0
"""The scale of head translations for the speed of the pose filter."""


class LandmarkSmoother:
    """One Euro smoothing of a face's landmarks (N, 2), speed measured in face sizes."""

    def __init__(self, settings: OneEuroSettings = LANDMARKS) -> None:
        self.filter = OneEuroFilter(settings)

    def reset(self) -> None:
        self.filter.reset()

    def __call__(self, points: np.ndarray, t: float) -> np.ndarray:
        """Smoothed landmarks (N, 2) of ``points`` (N, 2) seen at ``t`` seconds."""
        size = float(np.sqrt(np.ptp(points[:, 0]) * np.ptp(points[:, 1])))
        return self.filter(points, t, max(size, 1.0))

    def update(self, points: np.ndarray, t: float, good: bool) -> np.ndarray:
        """The landmarks of a frame: smoothed when the fit is ``good``; a failed fit's come
        back as they are and start the smoothing afresh."""
        if not good:
            self.reset()
            return points
        return self(points, t)

    def smoothed(self, fit: F | None, t: float) -> F | None:
        """A frame's fit with its landmarks smoothed (a copy: the tracker goes on from the raw
        fit), as the library and the fitter service both smooth; None (no face) resets."""
        if fit is None:
            self.reset()
            return None
        smoothed = copy.copy(fit)  # dataclasses.replace, without its overhead (no
        # __post_init__ to run again: only the points change)
        object.__setattr__(smoothed, "points", self.update(fit.points, t, fit.ok))
        return smoothed
