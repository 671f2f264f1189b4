"""POSIT (thesis Algorithm 9): known poses, agreement with SQPNP, bad input."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from aamcore.pose.errors import PoseError
from aamcore.pose.head_model import openface68
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.posit import Posit, flatness
from aamcore.pose.rotation import rotation_angle_deg, rotation_from_rpy

CAM = CameraIntrinsics.from_fov(640, 480, 60.0)


@pytest.fixture(scope="module")
def model() -> np.ndarray:
    return openface68().points


def random_poses(n: int, seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    rng = np.random.default_rng(seed)
    poses = []
    for _ in range(n):
        R = rotation_from_rpy(*rng.uniform(-40, 40, 3))
        T = np.array([rng.uniform(-80, 80), rng.uniform(-60, 60), rng.uniform(400, 1200)])
        poses.append((R, T))
    return poses


@pytest.mark.parametrize("refine", [0, 1])
def test_recovers_known_poses_exactly(model: np.ndarray, refine: int) -> None:
    posit = Posit(model, refine_iterations=refine, tolerance=1e-9)
    for R, T in random_poses(30, seed=1):
        est = posit.estimate(CAM.project(model, R, T), CAM)
        assert est.converged and est.reliable and est.reason == "ok"
        assert rotation_angle_deg(est.R, R) < 1e-5
        assert np.allclose(est.T, T, atol=1e-4)
        assert est.rms_px < 1e-5
        assert 2 <= est.iterations < 30


def test_default_converges_in_few_iterations(model: np.ndarray) -> None:
    posit = Posit(model)
    its = [posit.estimate(CAM.project(model, R, T), CAM).iterations
           for R, T in random_poses(20, seed=2)]
    assert max(its) <= 8  # the thesis: "converges in about four iterations"


def test_translation_is_in_model_units_and_origin(model: np.ndarray) -> None:
    R, T = random_poses(1, seed=3)[0]
    uv = CAM.project(model, R, T)
    in_cm = Posit(model / 10.0).estimate(uv, CAM)
    assert np.allclose(in_cm.T, T / 10.0, atol=1e-5)
    offset = np.array([5.0, -20.0, 30.0])
    shifted = Posit(model + offset).estimate(uv, CAM)
    assert np.allclose(shifted.T, T - R @ offset, atol=1e-4)
    assert shifted.distance == pytest.approx(np.linalg.norm(T - R @ offset))


def test_pose_properties(model: np.ndarray) -> None:
    R, T = rotation_from_rpy(12.0, -7.0, 25.0), np.array([0.0, 0.0, 700.0])
    est = Posit(model).estimate(CAM.project(model, R, T), CAM)
    assert est.rpy == pytest.approx((12.0, -7.0, 25.0), abs=1e-6)
    assert est.distance == pytest.approx(700.0, abs=1e-4)


def sqpnp_and_posit_errors(model: np.ndarray, refine: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(4)
    posit = Posit(model, refine_iterations=refine)
    errs = []
    for R, T in random_poses(150, seed=5):
        uv = CAM.project(model, R, T) + rng.normal(0, 1.0, (len(model), 2))
        est = posit.estimate(uv, CAM)
        _, rvec, tvec = cv2.solvePnP(model, uv, CAM.K, None, flags=cv2.SOLVEPNP_SQPNP)
        errs.append([rotation_angle_deg(est.R, R), rotation_angle_deg(cv2.Rodrigues(rvec)[0], R),
                     abs(est.distance - np.linalg.norm(T)),
                     abs(np.linalg.norm(tvec) - np.linalg.norm(T))])
    e = np.mean(errs, axis=0)
    return e[[0, 2]], e[[1, 3]]


@pytest.mark.parametrize("refine", [0, 1])
def test_as_accurate_as_sqpnp_with_1px_noise(model: np.ndarray, refine: int) -> None:
    ours, sqpnp = sqpnp_and_posit_errors(model, refine)
    assert np.all(ours <= 1.2 * sqpnp), (ours, sqpnp)
    assert ours[0] < 1.0  # degrees
    if refine:
        assert ours[0] <= 1.02 * sqpnp[0]


def test_undistorts_points_first(model: np.ndarray) -> None:
    K = np.array([[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]])
    cam = CameraIntrinsics(K, np.array([-0.3, 0.1, 0.0, 0.0, 0.0]), 640, 480)
    R, T = rotation_from_rpy(5, 10, -30), np.array([60.0, 40.0, 450.0])
    uv = cam.project(model, R, T)
    est = Posit(model).estimate(uv, cam)
    assert rotation_angle_deg(est.R, R) < 1e-4 and np.allclose(est.T, T, atol=1e-2)
    ignoring = Posit(model).estimate(uv, K)  # a bare K: no distortion model
    assert rotation_angle_deg(ignoring.R, R) > 0.2


def test_weights_drop_outliers(model: np.ndarray) -> None:
    R, T = rotation_from_rpy(-10, 15, 20), np.array([0.0, 0.0, 600.0])
    uv = CAM.project(model, R, T)
    uv[48:68] += 40.0  # a mouth the tracker lost
    posit = Posit(model)
    plain = posit.estimate(uv, CAM)
    assert rotation_angle_deg(plain.R, R) > 2.0
    weights = np.ones(68)
    weights[48:68] = 0.0
    weighted = posit.estimate(uv, CAM, weights=weights)
    assert weighted.reliable
    assert rotation_angle_deg(weighted.R, R) < 1e-4
    assert np.allclose(weighted.T, T, atol=1e-2)


def test_model_with_too_few_or_coplanar_points() -> None:
    with pytest.raises(PoseError, match="at least 4"):
        Posit(np.random.default_rng(0).normal(size=(3, 3)))
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 0]], float)
    assert flatness(square) == pytest.approx(0.0)
    with pytest.raises(PoseError, match="coplanar.*non-coplanar.*plane_pose"):
        Posit(square)
    with pytest.raises(PoseError, match=r"\(N, 3\)"):
        Posit(np.zeros((10, 2)))
    with pytest.raises(PoseError, match="not finite"):
        Posit(np.array([[0, 0, 0], [1, 0, 0], [0, 1, np.nan], [0, 0, 1]], float))


def test_bad_image_points_and_weights(model: np.ndarray) -> None:
    posit = Posit(model)
    uv = CAM.project(model, np.eye(3), np.array([0.0, 0.0, 600.0]))
    bad = uv.copy()
    bad[[5, 40]] = [np.nan, np.inf]
    with pytest.raises(PoseError, match=r"\[5, 40\].*not finite"):
        posit.estimate(bad, CAM)
    with pytest.raises(PoseError, match=r"\(68, 2\)"):
        posit.estimate(uv[:10], CAM)
    with pytest.raises(PoseError, match="non-negative"):
        posit.estimate(uv, CAM, weights=-np.ones(68))
    few = np.zeros(68)
    few[:3] = 1.0
    with pytest.raises(PoseError, match="only 3 points"):
        posit.estimate(uv, CAM, weights=few)
    # Four brow points lie nearly on a line: the weighted model is degenerate.
    line = np.zeros(68)
    line[[17, 18, 19, 20]] = 1.0
    with pytest.raises(PoseError, match="coplanar"):
        posit.estimate(uv, CAM, weights=line)


def test_non_convergence_is_flagged(model: np.ndarray) -> None:
    R, T = rotation_from_rpy(10, 30, -35), np.array([0.0, 0.0, 400.0])
    est = Posit(model, max_iterations=2, tolerance=1e-12).estimate(
        CAM.project(model, R, T), CAM)
    assert not est.converged and not est.reliable
    assert "did not converge in 2 iterations" in est.reason


def test_points_that_do_not_fit_the_model_are_flagged(model: np.ndarray) -> None:
    rng = np.random.default_rng(7)
    posit = Posit(model)
    flagged = 0
    for _ in range(10):
        est = posit.estimate(rng.uniform(100, 500, (68, 2)), CAM)
        if not est.reliable:
            flagged += 1
            assert est.reason != "ok"
    assert flagged == 10


def test_face_seen_from_behind_is_flagged(model: np.ndarray) -> None:
    uv = CAM.project(model, np.eye(3), np.array([0.0, 0.0, 600.0]))
    uv[:, 0] = 2 * CAM.K[0, 2] - uv[:, 0]  # left and right swapped: the back of a head
    assert Posit(model).estimate(uv, CAM).reliable  # a generic rigid model: a valid pose
    est = openface68().posit().estimate(uv, CAM)
    assert not est.reliable and "faces away" in est.reason
    turned = CAM.project(model, rotation_from_rpy(0, 0, 60), np.array([0.0, 0.0, 600.0]))
    assert openface68().posit().estimate(turned, CAM).reliable
