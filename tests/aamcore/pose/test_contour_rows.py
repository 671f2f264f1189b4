"""aamcore.pose.contour_rows: the stacked rows equal the plain formulation (the outline model's
silhouette and the reprojection rows of each point), at any pose, with points missing."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.pose.contour_rows import ContourRows
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.refine import reprojection_rows
from aamcore.pose.robust import ContourPose
from aamcore.pose.rotation import rotation_from_rpy
from aamcore.pose.visibility import visibility_weights

CAM = CameraIntrinsics.from_fov(640, 480, 60.0)


@pytest.fixture(scope="module")
def contour() -> ContourPose:
    return ContourPose()


def plain_rows(est: ContourPose, R: np.ndarray, T: np.ndarray, xy: np.ndarray,
               inside: np.ndarray) -> tuple[np.ndarray, ...]:
    """The rows as the module notes define them, point by point."""
    inner, jaw = est.inner, est.outline.landmarks
    S, d, _ = est.outline.silhouette(R, T, CAM.K)
    fxy = np.array(CAM.focal)
    r_in, J_in = reprojection_rows(R, T, est.X[inner], xy[inner], fxy)
    r_jaw, J_jaw = reprojection_rows(R, T, S, xy[jaw], fxy)
    L = len(jaw)
    r = np.concatenate([r_in, r_jaw[:L] * d[:, 0] + r_jaw[L:] * d[:, 1]])
    J = np.vstack([J_in, J_jaw[:L] * d[:, :1] + J_jaw[L:] * d[:, 1:]])
    vis = visibility_weights(est.X[inner], est.normals[inner], R, T, *est.ramp_deg)
    w_in = inside[inner] * vis
    return r, J, np.concatenate([w_in, w_in, est.outline_weight * inside[jaw]]), S


@pytest.mark.parametrize("rpy", [(0, 0, 0), (10, -20, 45), (-5, 30, -70), (20, 10, 85)])
def test_rows_equal_the_plain_formulation(contour: ContourPose, rpy: tuple) -> None:
    R, T = rotation_from_rpy(*rpy), np.array([20.0, -10.0, 650.0])
    rng = np.random.default_rng(abs(int(rpy[2])))
    xy = CAM.normalize(CAM.project(contour.X, R, T) + rng.normal(0.0, 3.0, (68, 2)))
    inside = rng.uniform(size=68) > 0.1
    rows = ContourRows(contour.inner, contour.X[contour.inner], contour.normals[contour.inner],
                       contour.outline, *contour.ramp_deg)
    frame = rows.frame(xy, inside, np.array(CAM.focal), contour.outline_weight)
    # at a pose off the one that made the landmarks: residuals are not zero
    R1 = rotation_from_rpy(3.0, -2.0, 4.0) @ R
    got = rows.at(R1, T + 5.0, frame)
    assert got is not None
    r, Jt, w = got
    got = (r, Jt.T, w, rows.outline_points(frame))
    for a, b in zip(got, plain_rows(contour, R1, T + 5.0, xy, inside), strict=True):
        assert a.shape == b.shape and np.allclose(a, b, rtol=1e-10, atol=1e-9)


def test_missing_landmarks_give_rows_without_weight(contour: ContourPose) -> None:
    R, T = rotation_from_rpy(0.0, 0.0, 20.0), np.array([0.0, 0.0, 600.0])
    xy = CAM.normalize(CAM.project(contour.X, R, T))
    xy[[3, 30]] = np.nan
    inside = np.isfinite(xy).all(axis=1)
    rows = ContourRows(contour.inner, contour.X[contour.inner], None, contour.outline)
    r, J, w = rows.at(R, T, rows.frame(xy, inside, np.array(CAM.focal), 0.5))
    assert np.all(np.isfinite(r)) and np.all(np.isfinite(J))
    n = len(contour.inner)
    nose = int(np.flatnonzero(contour.inner == 30)[0])
    assert w[nose] == w[n + nose] == 0.0 and w[2 * n + 3] == 0.0
    assert np.count_nonzero(w == 0.0) == 3


def test_a_point_behind_the_camera_gives_no_rows(contour: ContourPose) -> None:
    rows = ContourRows(contour.inner, contour.X[contour.inner], None, None)
    xy = np.zeros((68, 2))
    frame = rows.frame(xy, np.ones(68, bool), np.array(CAM.focal), 0.5)
    assert rows.at(np.eye(3), np.array([0.0, 0.0, 30.0]), frame) is None  # the nose behind
    assert rows.at(np.eye(3), np.array([0.0, 0.0, 600.0]), frame) is not None
