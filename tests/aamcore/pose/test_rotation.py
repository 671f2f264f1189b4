"""Roll-pitch-yaw angles and rotation helpers (thesis eqs 14.1-14.3)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aamcore.pose.rotation import (
    nearest_rotation,
    rotation_angle_deg,
    rotation_from_rpy,
    rpy_from_rotation,
)

angle = st.floats(-170.0, 170.0)


@settings(max_examples=200, deadline=None)
@given(roll=angle, pitch=angle, yaw=st.floats(-89.0, 89.0))
def test_rpy_round_trip(roll: float, pitch: float, yaw: float) -> None:
    R = rotation_from_rpy(roll, pitch, yaw)
    assert np.allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.isclose(np.linalg.det(R), 1.0)
    back = rpy_from_rotation(R)
    assert np.allclose(back, (roll, pitch, yaw), atol=1e-7)
    assert np.allclose(rotation_from_rpy(*back), R, atol=1e-12)


def test_eq_14_1_order_is_z_then_y_then_x() -> None:
    # Each angle alone is a rotation about its own axis.
    assert np.allclose(rotation_from_rpy(30, 0, 0) @ [0, 0, 1], [0, 0, 1])  # roll about z
    assert np.allclose(rotation_from_rpy(0, 30, 0) @ [1, 0, 0], [1, 0, 0])  # pitch about x
    assert np.allclose(rotation_from_rpy(0, 0, 30) @ [0, 1, 0], [0, 1, 0])  # yaw about y
    Rz, Ry = rotation_from_rpy(10, 0, 0), rotation_from_rpy(0, 0, 20)
    Rx = rotation_from_rpy(0, 30, 0)
    assert np.allclose(rotation_from_rpy(10, 30, 20), Rz @ Ry @ Rx)


def test_sign_conventions_on_a_nose() -> None:
    nose = np.array([0.0, 0.0, -40.0])  # in front of the head, toward the camera
    assert (rotation_from_rpy(0, 0, 20) @ nose)[0] < 0  # positive yaw: nose to image left
    assert (rotation_from_rpy(0, 20, 0) @ nose)[1] > 0  # positive pitch: nose down
    right = np.array([50.0, 0.0, 0.0])
    assert (rotation_from_rpy(20, 0, 0) @ right)[1] > 0  # positive roll: clockwise in the image


def test_radians_option() -> None:
    R = rotation_from_rpy(0.1, 0.2, 0.3, degrees=False)
    assert np.allclose(rpy_from_rotation(R, degrees=False), (0.1, 0.2, 0.3))


def test_nearest_rotation_and_angle() -> None:
    rng = np.random.default_rng(0)
    R = rotation_from_rpy(10, -20, 30)
    noisy = R + rng.normal(0, 1e-3, (3, 3))
    fixed = nearest_rotation(noisy)
    assert np.allclose(fixed @ fixed.T, np.eye(3), atol=1e-12)
    assert np.isclose(np.linalg.det(fixed), 1.0)
    assert rotation_angle_deg(fixed, R) < 0.2
    assert rotation_angle_deg(rotation_from_rpy(0, 0, 25), np.eye(3)) == pytest.approx(25.0)


def test_rpy_rejects_bad_input() -> None:
    with pytest.raises(ValueError, match="3, 3"):
        rpy_from_rotation(np.eye(2))
    with pytest.raises(ValueError, match="finite"):
        rpy_from_rotation(np.full((3, 3), np.nan))
