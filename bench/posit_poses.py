"""Random head poses before the bench's camera, and the errors of an estimate against them
(shared by ``bench_posit.py`` and ``posit_subsets.py``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.rotation import rotation_from_rpy, rpy_from_rotation

CAMERA = CameraIntrinsics.from_fov(640, 480, 60.0)

@dataclass(frozen=True)
class Truth:
    """A known pose: rotation (3, 3), translation (3,) in mm."""

    R: np.ndarray
    T: np.ndarray


def random_pose(rng: np.random.Generator, distance_mm: float | None = None) -> Truth:
    """Roll, pitch, yaw uniform in +-40 deg; |T| uniform 400-1200 mm unless given."""
    R = rotation_from_rpy(*rng.uniform(-40.0, 40.0, 3))
    dist = rng.uniform(400.0, 1200.0) if distance_mm is None else distance_mm
    u = rng.uniform(0.25, 0.75) * CAMERA.width
    v = rng.uniform(0.25, 0.75) * CAMERA.height
    ray = np.linalg.solve(CAMERA.K, [u, v, 1.0])
    return Truth(R, ray / np.linalg.norm(ray) * dist)


def errors(R: np.ndarray, T: np.ndarray, truth: Truth) -> np.ndarray:
    """|roll|, |pitch|, |yaw| errors (deg) and |distance| error (cm), shape (4,)."""
    d_ang = np.array(rpy_from_rotation(R)) - np.array(rpy_from_rotation(truth.R))
    d_ang = (d_ang + 180.0) % 360.0 - 180.0
    d_cm = (np.linalg.norm(T) - np.linalg.norm(truth.T)) / 10.0
    return np.abs(np.append(d_ang, d_cm))
