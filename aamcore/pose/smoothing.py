"""Temporal smoothing of a head pose: the One Euro filter (:mod:`aamcore.smoothing`) on
the rotation, smoothed as a matrix and projected back onto the rotations, and on the
translation."""

from __future__ import annotations

import numpy as np

from aamcore.pose.rotation import nearest_rotation
from aamcore.smoothing import HEAD_SIZE_MM, POSE, OneEuroFilter, OneEuroSettings

SPEED_SCALE = np.array([1.0] * 9 + [HEAD_SIZE_MM] * 3)
"""What divides each value's speed: rotation entries as they are, translations in head
sizes."""


class PoseSmoother:
    """One Euro smoothing of a head pose: rotation (3, 3) and translation (3,) in mm, as one
    filter of their 12 values (each value is filtered alone)."""

    def __init__(self, settings: OneEuroSettings = POSE) -> None:
        self.filter = OneEuroFilter(settings)

    def reset(self) -> None:
        self.filter.reset()

    def __call__(self, R: np.ndarray, T: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Smoothed ``(R, T)`` at ``t`` seconds; ``R`` stays a rotation."""
        pose = self.filter(np.concatenate([np.ravel(R), np.ravel(T)]), t, SPEED_SCALE)
        return nearest_rotation(pose[:9].reshape(3, 3)), pose[9:]
