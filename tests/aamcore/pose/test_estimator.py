"""aamcore.pose.estimator: the estimators the stack can run, their reasons, and resets."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore import defaults
from aamcore.pose.errors import PoseError
from aamcore.pose.estimator import Cameras, HeadPoseEstimator, HeadPoseTracker
from aamcore.pose.head_model import openface68
from aamcore.pose.robust import ContourPose
from aamcore.pose.rotation import rotation_angle_deg, rotation_from_rpy

SIZE = (640, 480)
CAMERA = Cameras(60.0).at(*SIZE)


def annotated(yaw: float, pitch: float = 0.0, T: tuple = (0.0, 0.0, 650.0)) -> np.ndarray:
    """Landmarks of the mean head: inner points fixed, the jaw on the outline seen."""
    contour = ContourPose()
    R, T = rotation_from_rpy(0.0, pitch, yaw), np.array(T)
    uv = CAMERA.project(contour.X, R, T)
    jaw, _, _ = contour.outline.silhouette(R, T, CAMERA.K)
    uv[:17] = CAMERA.project(jaw, R, T)
    return uv


def test_the_default_is_contour() -> None:
    est = HeadPoseEstimator()
    assert defaults.POSE_ESTIMATOR == "contour" == est.method
    assert est.model.name == "openface_mean68" and len(est.model.indices) == 68


@pytest.mark.parametrize("method", defaults.POSE_ESTIMATORS)
def test_every_method_finds_a_frontal_pose(method: str) -> None:
    pose = HeadPoseEstimator(method=method).estimate(annotated(0.0), *SIZE)
    assert pose.estimate.reliable and pose.reason == ""
    assert rotation_angle_deg(pose.estimate.R, np.eye(3)) < 0.5
    assert (np.isnan(pose.angle_sd_deg) if method == "posit" else pose.angle_sd_deg < 0.1)


def test_contour_holds_at_large_yaw_where_posit_on_all_points_does_not() -> None:
    uv = annotated(55.0)
    truth = rotation_from_rpy(0.0, 0.0, 55.0)
    contour = HeadPoseEstimator().estimate(uv, *SIZE).estimate
    all68 = HeadPoseEstimator(model=openface68(), method="posit").estimate(uv, *SIZE).estimate
    assert rotation_angle_deg(contour.R, truth) < 1e-3
    assert rotation_angle_deg(all68.R, truth) > 3.0


def test_an_unreliable_pose_says_why_and_bad_input_gives_none() -> None:
    est = HeadPoseEstimator()
    profile = est.estimate(annotated(85.0), *SIZE)
    assert not profile.estimate.reliable and profile.reason.startswith(
        ("profile", "the model faces away"))
    with pytest.raises(PoseError, match="out of the frame"):
        est.estimate(annotated(0.0, T=(900.0, 0.0, 600.0)), *SIZE)
    with pytest.raises(PoseError, match="unknown pose estimator"):
        HeadPoseEstimator(method="eos")
    with pytest.raises(PoseError, match="iBUG-68"):
        HeadPoseEstimator(model=openface68(rigid_subset="no_jaw"), method="contour")


def test_a_failed_fit_resets_the_calibration_and_is_not_learned() -> None:
    estimator = HeadPoseEstimator(method="contour+calib")
    calib = estimator.calibration
    assert calib is not None
    poses = HeadPoseTracker(estimator)
    for k, yaw in enumerate(np.linspace(-40, 40, 12)):
        poses.update(annotated(float(yaw), 5.0 * (k % 3 - 1)), *SIZE, t=k / 30)
        assert estimator.wait(timeout=60.0)
    assert calib.refinements == 1
    poses.update(annotated(10.0), *SIZE, t=1.0, fit_failed=True)
    assert calib.refinements == 0 and len(calib._cells) == 0
    with pytest.raises(PoseError):
        poses.update(np.full((68, 2), np.nan), *SIZE, t=1.1)
