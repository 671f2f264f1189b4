"""OpenCV camera matrices as OpenGL projections."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from aamcore.ar.projection import (
    pose_matrix,
    project_points,
    projection_from_intrinsics,
)

K = np.array([[812.0, 0.0, 322.4], [0.0, 805.0, 236.9], [0.0, 0.0, 1.0]])
W, H = 640, 480


def _rotation(rvec: list[float]) -> np.ndarray:
    return cv2.Rodrigues(np.array(rvec, dtype=np.float64))[0]


def _gl_pixels(points: np.ndarray, R: np.ndarray, T: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Where the GL pipeline puts ``points`` (N, 3), in OpenCV pixel coordinates."""
    P = projection_from_intrinsics(K, W, H, near=10.0, far=5000.0)
    clip = (P @ pose_matrix(R, T) @ np.column_stack([points, np.ones(len(points))]).T).T
    ndc = clip[:, :3] / clip[:, 3:]
    # window coordinates have pixel centres at half-integers, rows from the read-back start
    return (ndc[:, :2] + 1.0) / 2.0 * [W, H] - 0.5


def test_projection_puts_points_on_the_opencv_pixels() -> None:
    rng = np.random.default_rng(3)
    points = rng.uniform(-80, 80, (50, 3))
    R, T = _rotation([0.2, -0.5, 0.1]), np.array([15.0, -10.0, 650.0])
    expected, _ = cv2.projectPoints(points, cv2.Rodrigues(R)[0], T, K, None)
    np.testing.assert_allclose(_gl_pixels(points, R, T, K), expected[:, 0], atol=1e-6)
    np.testing.assert_allclose(project_points(points, R, T, K), expected[:, 0], atol=1e-9)
    # cv2.projectPoints ignores a skew term; the GL projection keeps it, as K @ X does
    skewed = K + [[0.0, 3.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
    np.testing.assert_allclose(
        _gl_pixels(points, R, T, skewed), project_points(points, R, T, skewed), atol=1e-6
    )


def test_depth_runs_from_near_to_far() -> None:
    P = projection_from_intrinsics(K, W, H, near=10.0, far=5000.0)
    for z, expected in ((10.0, -1.0), (5000.0, 1.0)):
        clip = P @ [0.0, 0.0, z, 1.0]
        assert clip[2] / clip[3] == pytest.approx(expected)
    nearer, farther = (P @ [0, 0, 300.0, 1.0]), (P @ [0, 0, 900.0, 1.0])
    assert nearer[2] / nearer[3] < farther[2] / farther[3]


def test_bad_camera_or_pose_is_refused() -> None:
    with pytest.raises(ValueError, match="near < far"):
        projection_from_intrinsics(K, W, H, near=100.0, far=10.0)
    with pytest.raises(ValueError, match="camera matrix"):
        projection_from_intrinsics(np.diag([800.0, 800.0, 2.0]), W, H, 1.0, 10.0)
    with pytest.raises(ValueError, match=r"\(3, 3\)"):
        projection_from_intrinsics(np.eye(2), W, H, 1.0, 10.0)
    with pytest.raises(ValueError, match="rotation"):
        pose_matrix(np.diag([1.0, 1.0, -1.0]), np.zeros(3))
    with pytest.raises(ValueError, match="T"):
        pose_matrix(np.eye(3), np.zeros(4))
