"""aamcore.pose.reliability: each check, in order, with its reason."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from aamcore.pose.reliability import FitQuality, ReliabilityLimits, reason_key
from aamcore.pose.rotation import rotation_from_rpy

GOOD = FitQuality(1.0, 50.0, 0.9, 0.0, np.array([0.5, 0.5, 0.5]), True)
T = np.array([0.0, 0.0, 600.0])


def test_a_good_pose_has_no_problem() -> None:
    assert ReliabilityLimits().problem(rotation_from_rpy(5, -10, 40), T, GOOD) == ""


@pytest.mark.parametrize(("change", "start"), [
    ({"outside_fraction": 0.3}, "points outside the frame or missing: 30 %"),
    ({"rms_px": 6.0}, "landmarks do not fit the head"),
    ({"rms_px": float("nan")}, "landmarks do not fit the head"),
    ({"inlier_fraction": 0.4}, "too many outlying landmarks: 40 %"),
    ({"angle_sd_deg": np.array([0.5, 4.0, 0.5])}, "poorly determined: predicted angle sd 4.0"),
    ({"converged": False}, "did not converge"),
])
def test_each_quality_check(change: dict, start: str) -> None:
    quality = dataclasses.replace(GOOD, **change)
    assert ReliabilityLimits().problem(np.eye(3), T, quality).startswith(start)


def test_pose_checks_come_first() -> None:
    limits = ReliabilityLimits()
    bad = dataclasses.replace(GOOD, rms_px=100.0)
    assert limits.problem(np.eye(3), -T, bad).startswith("no valid pose")
    assert limits.problem(rotation_from_rpy(0, 0, 180), T, bad).startswith(
        "the model faces away from the camera")
    assert limits.problem(rotation_from_rpy(0, 0, -80), T, bad).startswith(
        "profile: yaw -80 deg")
    assert limits.problem(np.full((3, 3), np.nan), T, GOOD).startswith("no valid pose")


def test_reason_keys_count_alike_reasons_as_one() -> None:
    assert reason_key("profile: yaw +80 deg beyond +-75") == "profile"
    assert reason_key("fit failed: texture error 31.2 too large") == "fit failed"
    assert reason_key("POSIT did not converge in 100 iterations") == (
        "POSIT did not converge in # iterations")
    assert reason_key("") == ""
