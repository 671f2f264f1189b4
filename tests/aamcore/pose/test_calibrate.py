"""aamcore.pose.calibrate: the head model adapts to a face that differs from the mean one,
off the per-frame path, and forgets it on reset."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from aamcore.pose.calibrate import CalibrationSettings, OnlineCalibration
from aamcore.pose.head_model import openface68
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.rotation import rotation_angle_deg, rotation_from_rpy

CAM = CameraIntrinsics.from_fov(640, 480, 60.0)
POSES = [(float(y), p) for y in np.linspace(-50, 50, 21) for p in (-15.0, 0.0, 15.0)]
"""Yaw and pitch of the frames shown, in order."""


def person_frames(calib: OnlineCalibration, seed: int = 0
                  ) -> Callable[[float, float], tuple[np.ndarray, np.ndarray]]:
    """Landmarks of a person whose nose is 8 mm longer than the mean one's, 0.3 px noise."""
    person = openface68().points.copy()
    person[27:36, 2] -= 8.0
    rng = np.random.default_rng(seed)
    outline = calib.current.outline

    def frame(yaw: float, pitch: float) -> tuple[np.ndarray, np.ndarray]:
        R = rotation_from_rpy(0.0, pitch, yaw)
        T = np.array([0.0, 0.0, 650.0])
        uv = CAM.project(person, R, T)
        jaw, _, _ = outline.silhouette(R, T, CAM.K)
        uv[:17] = CAM.project(jaw, R, T)
        return uv + rng.normal(0.0, 0.3, uv.shape), R

    return frame


def nose_relief(points: np.ndarray) -> float:
    """How far the nose stands out in front of the eyes, mm."""
    return float(points[36:48, 2].mean() - points[27:36, 2].mean())


@pytest.mark.parametrize("background", [True, False])
def test_a_deeper_nose_is_learned_and_the_turned_pose_improves(background: bool) -> None:
    calib = OnlineCalibration(background=background)
    frame = person_frames(calib)
    errors_before = []
    for yaw, pitch in POSES:
        uv, R = frame(yaw, pitch)
        est = calib.estimate(uv, CAM)
        if calib.refinements == 0 and abs(yaw) > 30:
            errors_before.append(rotation_angle_deg(est.R, R))
        assert calib.wait(timeout=60.0)  # the tests wait; the stack does not
    assert calib.refinements > 0 and calib.failures == 0
    assert nose_relief(calib.points) > nose_relief(openface68().points) + 3.0
    errors_after = [rotation_angle_deg(calib.estimate(uv, CAM).R, R)
                    for uv, R in (frame(y, 0.0) for y in (-45.0, -35.0, 35.0, 45.0))]
    assert np.mean(errors_after) < 0.75 * np.mean(errors_before)
    calib.reset()
    assert calib.refinements == 0 and np.array_equal(calib.points, openface68().points)


def test_the_refinement_runs_in_the_background_and_is_swapped_in_whole() -> None:
    calib = OnlineCalibration(settings=CalibrationSettings(every=5, min_frames=5))
    frame = person_frames(calib)
    mean = calib.current
    for yaw, pitch in POSES[:9]:
        calib.estimate(frame(yaw, pitch)[0], CAM)
    # The fifth reliable frame (in a fifth pose cell) started the one refinement; the mean
    # model stays current until the refined one replaces it as a whole.
    assert calib.current is mean or calib.refinements == 1
    assert calib.wait(timeout=60.0) and not calib.pending
    assert calib.refinements == 1 and calib.current is not mean
    assert calib.current.model.name == "openface_mean68+calibrated"


def test_a_reset_discards_the_refinement_under_way() -> None:
    calib = OnlineCalibration(settings=CalibrationSettings(every=5, min_frames=5))
    frame = person_frames(calib)
    for yaw, pitch in POSES[:5]:
        calib.estimate(frame(yaw, pitch)[0], CAM)
    calib.reset()  # before or after the refinement is done: either way it is gone
    assert calib.wait(timeout=60.0)
    assert calib.refinements == 0 and calib.current is calib._mean
    assert np.array_equal(calib.points, openface68().points)


def test_frames_not_to_learn_from_are_not_kept() -> None:
    calib = OnlineCalibration(background=False)
    frame = person_frames(calib)
    for yaw, pitch in POSES[:30]:
        est = calib.estimate(frame(yaw, pitch)[0], CAM, learn=False)
        assert est.reliable
    assert calib.refinements == 0 and not calib.pending
