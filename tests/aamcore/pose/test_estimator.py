"""aamcore.pose.estimator: the estimators the stack can run, their reasons, resets, and bad
input (profiles, mirror images, points far outside the frame, NaN and scrambled points):
no pose or an unreliable one with a reason, never a reliable wrong one."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore import defaults
from aamcore.pose.errors import PoseError
from aamcore.pose.estimator import Cameras, HeadPoseEstimator, HeadPoseTracker
from aamcore.pose.head_model import openface68
from aamcore.pose.robust import ContourPose
from aamcore.pose.rotation import rotation_angle_deg, rotation_from_rpy
from aamcore.synth.head import synth_head
from aamcore.synth.sequence import PoseTruth, annotated_landmarks

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


def test_an_estimator_follows_its_face_from_the_last_pose_until_reset() -> None:
    est = HeadPoseEstimator()
    uv = annotated(30.0, 5.0) + np.random.default_rng(2).normal(0.0, 1.5, (68, 2))
    first = est.estimate(uv, *SIZE).estimate
    again = est.estimate(uv, *SIZE).estimate
    assert again.iterations == 1 < first.iterations
    assert rotation_angle_deg(again.R, first.R) < 0.02
    with pytest.raises(PoseError):
        est.estimate(np.full((68, 2), np.nan), *SIZE)
    after_error = est.estimate(uv, *SIZE).estimate
    est.reset()
    after_reset = est.estimate(uv, *SIZE).estimate
    for cold in (after_error, after_reset):  # from POSIT again, as the first
        assert cold.iterations == first.iterations and np.array_equal(cold.R, first.R)


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


def _bad_inputs() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Hard cases on the rendered synthetic head as an annotator marks it: landmarks and
    the true rotation."""
    head = synth_head()

    def seen(yaw: float, T: tuple = (0.0, 0.0, 600.0)) -> tuple[np.ndarray, np.ndarray]:
        pose = PoseTruth(rotation_from_rpy(0.0, 0.0, yaw), np.array(T))
        return annotated_landmarks(head, [pose], CAMERA)[0], pose.R

    uv, R = seen(20.0)
    mirrored = uv.copy()
    mirrored[:, 0] = 2.0 * CAMERA.K[0, 2] - mirrored[:, 0]
    nan_eyes, nan_all = uv.copy(), np.full((68, 2), np.nan)
    nan_eyes[27:48] = np.nan
    cases = {"profile 80": seen(80.0), "profile 90": seen(90.0), "mirror": (mirrored, R),
             "half out": seen(20.0, (350.0, 0.0, 600.0)),
             "far out": seen(20.0, (900.0, 0.0, 600.0)),
             "far out below": seen(0.0, (0.0, 2000.0, 600.0)),
             "eyes and nose NaN": (nan_eyes, R), "all NaN": (nan_all, R),
             "noise 25 px": (uv + np.random.default_rng(0).normal(0.0, 25.0, uv.shape), R)}
    for seed in range(4):
        cases[f"scrambled {seed}"] = (uv[np.random.default_rng(seed).permutation(68)], R)
    return cases


BAD = _bad_inputs()


@pytest.mark.parametrize("case", sorted(BAD))
@pytest.mark.parametrize("method", ["contour", "contour+calib"])
def test_bad_input_gives_no_pose_or_an_unreliable_one_with_a_reason(method: str, case: str
                                                                     ) -> None:
    landmarks, _ = BAD[case]
    try:
        pose = HeadPoseEstimator(method=method).estimate(landmarks, *SIZE)
    except PoseError as exc:
        assert str(exc)
        return
    assert not pose.estimate.reliable and pose.reason and pose.reason != "ok"


def test_a_turn_of_70_degrees_is_still_reliable_and_right() -> None:
    head = synth_head()
    pose = PoseTruth(rotation_from_rpy(0.0, 0.0, 70.0), np.array([0.0, 0.0, 600.0]))
    uv = annotated_landmarks(head, [pose], CAMERA)[0]
    est = HeadPoseEstimator().estimate(uv, *SIZE).estimate
    assert est.reliable and rotation_angle_deg(est.R, pose.R) < 5.0
