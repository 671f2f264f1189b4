"""Plane pose from a homography (thesis appendix A), on a rendered checkerboard."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from aamcore.pose.errors import PoseError
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.plane_pose import plane_pose, pose_from_homography
from aamcore.pose.rotation import rotation_angle_deg, rotation_from_rpy

CAM = CameraIntrinsics.from_fov(640, 480, 60.0)
SQUARES = (9, 7)  # squares across, down: 8 x 6 inner corners
SQUARE_MM = 30.0
PX_PER_SQUARE = 64  # texture resolution


def homography(R: np.ndarray, T: np.ndarray, K: np.ndarray) -> np.ndarray:
    return K @ np.column_stack([R[:, 0], R[:, 1], T])


def render_board(R: np.ndarray, T: np.ndarray, supersample: int = 4) -> np.ndarray:
    """A checkerboard seen by CAM under pose (R, T), anti-aliased by supersampling."""
    cols, rows = SQUARES
    board = np.kron((np.add.outer(np.arange(rows), np.arange(cols)) % 2 == 0).astype(np.uint8),
                    np.ones((PX_PER_SQUARE, PX_PER_SQUARE), np.uint8)) * 255
    # A white margin of one square so that the outer corners are detectable.
    board = cv2.copyMakeBorder(board, PX_PER_SQUARE, PX_PER_SQUARE, PX_PER_SQUARE,
                               PX_PER_SQUARE, cv2.BORDER_CONSTANT, value=255)
    # Texture pixel centre (i, j) -> plane mm; the board origin is its first inner corner.
    mm = SQUARE_MM / PX_PER_SQUARE
    tex_to_plane = np.array([[mm, 0, -2 * SQUARE_MM + 0.5 * mm],
                             [0, mm, -2 * SQUARE_MM + 0.5 * mm], [0, 0, 1]])
    big = CAM.scaled_to(CAM.width * supersample, CAM.height * supersample)
    H = homography(R, T, big.K) @ tex_to_plane
    grey = cv2.warpPerspective(board, H, (big.width, big.height), flags=cv2.INTER_LINEAR,
                               borderValue=128)
    return cv2.resize(grey, (CAM.width, CAM.height), interpolation=cv2.INTER_AREA)


def board_corners_mm() -> np.ndarray:
    cols, rows = SQUARES[0] - 1, SQUARES[1] - 1
    j, i = np.mgrid[0:rows, 0:cols]
    return np.column_stack([i.ravel(), j.ravel()]).astype(np.float64) * SQUARE_MM


@pytest.mark.parametrize("sign", [1.0, -3.5])
def test_exact_homography_decomposes(sign: float) -> None:
    R, T = rotation_from_rpy(10, -25, 30), np.array([-50.0, 20.0, 700.0])
    R_est, T_est = pose_from_homography(sign * homography(R, T, CAM.K), CAM.K)
    assert np.allclose(R_est, R, atol=1e-10)
    assert np.allclose(T_est, T)


@pytest.mark.parametrize("rpy, T", [
    ((5.0, 20.0, -15.0), (-100.0, -60.0, 650.0)),
    ((-10.0, -30.0, 25.0), (-80.0, -70.0, 800.0)),
    ((0.0, 0.0, 0.0), (-105.0, -75.0, 500.0)),
])
def test_pose_of_a_rendered_checkerboard(rpy: tuple[float, float, float],
                                         T: tuple[float, float, float]) -> None:
    R, T = rotation_from_rpy(*rpy), np.array(T)
    image = render_board(R, T)
    pattern = (SQUARES[0] - 1, SQUARES[1] - 1)
    found, corners = cv2.findChessboardCorners(image, pattern)
    assert found
    corners = cv2.cornerSubPix(image, corners, (5, 5), (-1, -1),
                               (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 50, 1e-4))
    corners = corners.reshape(-1, 2)
    plane = board_corners_mm()
    # The board's 180-degree symmetry leaves the corner order to the detector: name the
    # first detected corner by the nearer of the two candidate board corners.
    expected_first = CAM.project(np.append(plane[0], 0.0)[None], R, T)[0]
    expected_last = CAM.project(np.append(plane[-1], 0.0)[None], R, T)[0]
    if np.linalg.norm(corners[0] - expected_last) < np.linalg.norm(corners[0] - expected_first):
        corners = corners[::-1]
    est = plane_pose(plane, corners, CAM)
    assert est.reliable and est.rms_px < 0.3
    assert rotation_angle_deg(est.R, R) < 0.5
    assert np.linalg.norm(est.T - T) < 0.01 * np.linalg.norm(T)
    assert np.allclose(est.R @ est.R.T, np.eye(3), atol=1e-12)


def test_plane_pose_bad_input() -> None:
    with pytest.raises(PoseError, match="at least 4"):
        plane_pose(np.zeros((3, 2)), np.zeros((3, 2)), CAM)
    with pytest.raises(PoseError, match="equal shape"):
        plane_pose(np.zeros((5, 2)), np.zeros((6, 2)), CAM)
    with pytest.raises(PoseError, match="not finite"):
        plane_pose(np.full((5, 2), np.nan), np.zeros((5, 2)), CAM)
    line = np.column_stack([np.arange(6.0), np.zeros(6)])
    with pytest.raises(PoseError, match="homography|degenerate"):
        plane_pose(line, line * 10 + 100, CAM)
    with pytest.raises(PoseError, match="finite"):
        pose_from_homography(np.full((3, 3), np.inf), CAM.K)
    with pytest.raises(PoseError, match="degenerate"):
        pose_from_homography(np.zeros((3, 3)), CAM.K)
