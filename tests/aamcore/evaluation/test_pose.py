"""Pose evaluation over sequences: statistics, bad frames, SQPNP comparison, plot."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from aamcore.evaluation.pose import (
    evaluate_pose_sequence,
    plot_pose_sequence,
    pose_parameters,
    posit_vs_sqpnp,
)
from aamcore.pose.head_model import openface68
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.rotation import rotation_from_rpy

CAM = CameraIntrinsics.from_fov(640, 480, 60.0)


def sequence(n: int = 12) -> tuple[list[np.ndarray], list[tuple[np.ndarray, np.ndarray]]]:
    model = openface68().points
    poses = [(rotation_from_rpy(0.0, 0.0, 40.0 * np.sin(t)), np.array([0.0, 0.0, 600.0 + 50 * t]))
             for t in np.linspace(0, 2 * np.pi, n)]
    return [CAM.project(model, R, T) for R, T in poses], poses


def test_exact_landmarks_give_zero_error() -> None:
    landmarks, poses = sequence()
    result = evaluate_pose_sequence(landmarks, poses, CAM, openface68())
    assert result["frames"] == result["estimated"] == 12
    for stats in result["errors"].values():
        assert stats["max_abs"] < 1e-4
    frame = result["per_frame"][3]
    assert frame["reliable"] and frame["estimate"]["yaw"] == pytest.approx(frame["truth"]["yaw"])


def test_missing_unreliable_and_failed_frames_are_counted() -> None:
    landmarks, poses = sequence(6)
    landmarks[1] = None
    landmarks[2] = np.random.default_rng(0).uniform(100, 500, (68, 2))  # not a face
    landmarks[3] = np.full((68, 2), np.nan)
    truths = [poses[0], {"R": poses[1][0].tolist(), "T": poses[1][1].tolist()}, *poses[2:]]
    result = evaluate_pose_sequence(landmarks, truths, CAM, openface68())
    assert (result["missing"], result["unreliable"], result["failed"]) == (1, 1, 1)
    assert result["estimated"] == 3
    assert "not finite" in result["per_frame"][3]["reason"]
    with pytest.raises(ValueError, match="5 landmark frames but 6"):
        evaluate_pose_sequence(landmarks[:5], truths, CAM, openface68())


def test_subset_model_selects_its_landmarks() -> None:
    landmarks, poses = sequence(4)
    result = evaluate_pose_sequence(landmarks, poses, CAM, openface68(rigid_subset=True))
    assert result["estimated"] == 4 and result["errors"]["yaw"]["max_abs"] < 1e-4


def test_posit_vs_sqpnp_with_noise() -> None:
    landmarks, poses = sequence(30)
    out = posit_vs_sqpnp(landmarks, poses, CAM, openface68(), noise_px=(0.0, 2.0))
    assert out["frames"] == 30 and [n["noise_px"] for n in out["noise"]] == [0.0, 2.0]
    exact, noisy = out["noise"]
    for name in ("POSIT", "POSIT+GN", "SQPNP"):
        assert exact[name]["yaw"]["mae"] < 1e-4
        assert 0.05 < noisy[name]["yaw"]["mae"] < 2.0
    assert noisy["POSIT+GN"]["yaw"]["mae"] <= 1.2 * noisy["SQPNP"]["yaw"]["mae"]


def test_pose_parameters() -> None:
    p = pose_parameters(rotation_from_rpy(1.0, 2.0, 3.0), np.array([0.0, 300.0, 400.0]))
    assert p == pytest.approx({"roll": 1.0, "pitch": 2.0, "yaw": 3.0, "distance_cm": 50.0})


def test_plot_writes_a_png(tmp_path: Path) -> None:
    landmarks, poses = sequence(10)
    result = evaluate_pose_sequence(landmarks, poses, CAM, openface68())
    path = plot_pose_sequence(result, tmp_path / "plots" / "pose.png", "test")
    image = cv2.imread(str(path))
    assert image is not None and image.shape[0] > 500 and image.shape[1] > 500
