"""The AAM pose parameters ``t = (s_x, s_y, t_x, t_y)`` (thesis eqs. 6.3, 6.4).

``s_x = s cos(theta) - 1`` and ``s_y = s sin(theta)``, so that ``t = 0`` is
the identity and the transform is linear in ``t``.
"""

from __future__ import annotations

import numpy as np

from aamcore.model.procrustes import Similarity


def pose_matrix(t: np.ndarray) -> np.ndarray:
    """The 2x3 matrix ``[[1 + s_x, -s_y, t_x], [s_y, 1 + s_x, t_y]]`` of eq. 6.4."""
    sx, sy, tx, ty = (float(v) for v in t)
    return np.array([[1.0 + sx, -sy, tx], [sy, 1.0 + sx, ty]])


def apply_pose(t: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Transform ``points`` (N, 2) by the pose ``t`` (4,)."""
    m = pose_matrix(t)
    return points @ m[:, :2].T + m[:, 2]


def pose_from_similarity(sim: Similarity) -> np.ndarray:
    """Pose parameters (4,) of a :class:`Similarity`."""
    return np.array(
        [
            sim.scale * np.cos(sim.angle) - 1.0,
            sim.scale * np.sin(sim.angle),
            sim.translation[0],
            sim.translation[1],
        ]
    )


def similarity_from_pose(t: np.ndarray) -> Similarity:
    """The :class:`Similarity` of pose parameters ``t`` (4,)."""
    a, b = 1.0 + float(t[0]), float(t[1])
    return Similarity(float(np.hypot(a, b)), float(np.arctan2(b, a)), np.array(t[2:4], float))


def compose_poses(outer: np.ndarray, inner: np.ndarray) -> np.ndarray:
    """Pose of ``x -> outer(inner(x))``, both (4,)."""
    m = pose_matrix(outer) @ np.vstack([pose_matrix(inner), [0.0, 0.0, 1.0]])
    return np.array([m[0, 0] - 1.0, m[1, 0], m[0, 2], m[1, 2]])


def invert_pose(t: np.ndarray) -> np.ndarray:
    """Pose of the inverse transform of ``t`` (4,)."""
    m = np.linalg.inv(np.vstack([pose_matrix(t), [0.0, 0.0, 1.0]]))
    return np.array([m[0, 0] - 1.0, m[1, 0], m[0, 2], m[1, 2]])
