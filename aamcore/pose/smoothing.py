"""Temporal smoothing of a head pose: the One Euro filter (:mod:`aamcore.smoothing`) on
the rotation, smoothed as a matrix and projected back onto the rotations, and on the
translation."""

from __future__ import annotations

import numpy as np

from aamcore.pose.rotation import nearest_rotation
from aamcore.smoothing import HEAD_SIZE_MM, POSE, OneEuroFilter, OneEuroSettings


class PoseSmoother:
    """One Euro smoothing of a head pose: rotation (3, 3) and translation (3,) in mm."""

    def __init__(self, settings: OneEuroSettings = POSE) -> None:
        self.rotation = OneEuroFilter(settings)
        self.translation = OneEuroFilter(settings)

    def reset(self) -> None:
        self.rotation.reset()
        self.translation.reset()

    def __call__(self, R: np.ndarray, T: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Smoothed ``(R, T)`` at ``t`` seconds; ``R`` stays a rotation."""
        R_s = nearest_rotation(self.rotation(R, t))
        return R_s, self.translation(T, t, HEAD_SIZE_MM)
