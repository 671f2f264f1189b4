"""OpenCV camera intrinsics and head pose as OpenGL matrices.

OpenCV's camera looks down +z with +y down and pixel centres at integer
coordinates; OpenGL's clip space has +y up, looks down -z, and window pixel
centres at half-integers. The usual conversion multiplies camera points by
``diag(1, -1, -1)`` (a half turn about x) and flips the rendered image
vertically when reading it back. This module avoids both: the projection
keeps OpenCV's camera axes (``w = z``, so points in front have z > 0) and
maps image row ``v`` to window row ``v + 0.5`` counted from the bottom.
The framebuffer is then upside down as seen by OpenGL, which is exactly the
order in which ``glReadPixels`` returns rows, so the read-back array is the
image in OpenCV's row order with no flip. Triangle winding is mirrored by
that choice, so renderers must not cull faces by winding.

With ``K = [[fx, s, cx], [0, fy, cy], [0, 0, 1]]``, an image of ``W x H``
pixels and depth range ``[near, far]`` (mm)::

    x_ndc = 2 (fx X/Z + s Y/Z + cx + 0.5) / W - 1
    y_ndc = 2 (fy Y/Z + cy + 0.5) / H - 1
    z_ndc = ((far + near) Z - 2 far near) / ((far - near) Z)

so ``z_ndc`` runs from -1 at ``Z = near`` to 1 at ``Z = far``.
"""

from __future__ import annotations

import numpy as np


def check_intrinsics(K: np.ndarray) -> np.ndarray:
    """Return ``K`` as a (3, 3) float64 camera matrix, or raise ValueError saying what is wrong."""
    K = np.asarray(K, dtype=np.float64)
    if K.shape != (3, 3) or not np.all(np.isfinite(K)):
        raise ValueError(f"K must be a finite (3, 3) matrix, got shape {K.shape}")
    if K[0, 0] <= 0 or K[1, 1] <= 0 or K[1, 0] != 0 or not np.allclose(K[2], [0, 0, 1]):
        raise ValueError(f"K is not an upper-triangular camera matrix with fx, fy > 0:\n{K}")
    return K


def check_pose(R: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return ``R`` (3, 3) and ``T`` (3,) as float64, or raise ValueError saying what is wrong."""
    R = np.asarray(R, dtype=np.float64)
    T = np.asarray(T, dtype=np.float64).reshape(-1)
    if R.shape != (3, 3) or T.shape != (3,):
        raise ValueError(f"pose needs R (3, 3) and T (3,), got {R.shape} and {T.shape}")
    if not (np.all(np.isfinite(R)) and np.all(np.isfinite(T))):
        raise ValueError("pose has NaN or infinite values")
    if not np.allclose(R @ R.T, np.eye(3), atol=1e-4) or np.linalg.det(R) < 0:
        raise ValueError("R is not a rotation matrix (orthonormal, determinant +1)")
    return R, T


def projection_from_intrinsics(
    K: np.ndarray, width: int, height: int, near: float, far: float
) -> np.ndarray:
    """The (4, 4) OpenGL projection of camera-frame points (OpenCV axes), see the module notes."""
    K = check_intrinsics(K)
    if not 0 < near < far:
        raise ValueError(f"need 0 < near < far, got near={near}, far={far}")
    fx, s, cx = K[0]
    fy, cy = K[1, 1], K[1, 2]
    P = np.zeros((4, 4))
    P[0] = [2 * fx / width, 2 * s / width, 2 * (cx + 0.5) / width - 1, 0]
    P[1] = [0, 2 * fy / height, 2 * (cy + 0.5) / height - 1, 0]
    P[2] = [0, 0, (far + near) / (far - near), -2 * far * near / (far - near)]
    P[3] = [0, 0, 1, 0]
    return P


def pose_matrix(R: np.ndarray, T: np.ndarray) -> np.ndarray:
    """The (4, 4) model-to-camera matrix of ``X_cam = R X + T``."""
    R, T = check_pose(R, T)
    M = np.eye(4)
    M[:3, :3] = R
    M[:3, 3] = T
    return M


def project_points(points: np.ndarray, R: np.ndarray, T: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Pixel positions (N, 2) of model points (N, 3) under pose ``(R, T)`` and camera ``K``."""
    R, T = check_pose(R, T)
    cam = np.asarray(points, dtype=np.float64) @ R.T + T
    uvw = cam @ check_intrinsics(K).T
    return uvw[:, :2] / uvw[:, 2:3]
