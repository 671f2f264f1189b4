"""Pose sweeps and the written sequence: video, per-frame JSON, exact landmarks."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.posit import Posit
from aamcore.pose.rotation import rotation_angle_deg, rpy_from_rotation
from aamcore.synth.head import synth_head
from aamcore.synth.sequence import (
    annotated_landmarks,
    exact_landmarks,
    load_sequence,
    sweep_poses,
    synthesize,
)
from aamcore.synth.texture import FaceTexture


@pytest.mark.parametrize("sweep", ["yaw", "pitch", "roll"])
def test_angle_sweeps_reach_40_degrees(sweep: str) -> None:
    poses = sweep_poses(sweep, 80)
    angles = np.array([getattr(rpy_from_rotation(p.R), sweep) for p in poses])
    assert angles.max() == pytest.approx(40.0) and angles.min() == pytest.approx(-40.0)
    assert angles[0] == 0.0
    assert np.max(np.abs(np.diff(angles))) < 4.0  # smooth
    assert all(p.T[2] == 600.0 and p.sweep == sweep for p in poses)


def test_angle_sweeps_reach_any_angle_below_90() -> None:
    yaws = [rpy_from_rotation(p.R).yaw for p in sweep_poses("yaw", 40, 60.0)]
    assert max(yaws) == pytest.approx(60.0) and min(yaws) == pytest.approx(-60.0)
    pitches = [rpy_from_rotation(p.R).pitch for p in sweep_poses("all", 80, 60.0)]
    assert max(pitches) == pytest.approx(60.0)
    for bad in (0.0, 90.0, 95.0):
        with pytest.raises(ValueError, match="max_angle"):
            sweep_poses("yaw", 10, bad)


def test_annotated_landmarks_differ_from_exact_only_on_the_jaw() -> None:
    head = synth_head()
    camera = CameraIntrinsics.from_fov(640, 480, 60.0)
    poses = sweep_poses("yaw", 8, 60.0)
    annotated = annotated_landmarks(head, poses, camera)
    exact = exact_landmarks(head, poses, camera)
    for a, e in zip(annotated, exact, strict=True):
        assert np.array_equal(a[17:], e[17:])
    assert np.abs(annotated[0][:17] - exact[0][:17]).max() < 3.0  # frontal: the jaw itself
    # At +60 the subject's right jaw (image left) is hidden: the annotator marks the
    # cheek's outline, outward of where the hidden jaw point is seen through the head.
    turned = int(np.argmax([rpy_from_rotation(p.R).yaw for p in poses]))
    assert exact[turned][2, 0] - annotated[turned][2, 0] > 5.0


def test_distance_sweep_and_all() -> None:
    d = np.array([p.T[2] for p in sweep_poses("distance", 80)])
    assert d[0] == 600.0 and d.max() == pytest.approx(1200.0) and d.min() == pytest.approx(400.0)
    assert np.max(np.abs(np.diff(d))) < 50.0
    poses = sweep_poses("all", 10)
    assert len(poses) == 10 and [p.sweep for p in poses][::3] == [
        "yaw",
        "pitch",
        "roll",
        "distance",
    ]
    with pytest.raises(ValueError, match="unknown sweep"):
        sweep_poses("spin", 10)
    with pytest.raises(ValueError, match="at least 4"):
        sweep_poses("all", 3)


def test_synthesize_writes_video_and_exact_truth(tmp_path: Path, texture: FaceTexture) -> None:
    camera = CameraIntrinsics.from_fov(320, 240, 60.0)
    path = synthesize(tmp_path / "seq", frames=8, sweep="all", camera=camera, texture=texture)
    summary, records = load_sequence(path.parent)
    assert summary["frames"] == 8 and len(records) == 8
    assert summary["texture_source"] == texture.source
    video = cv2.VideoCapture(str(path.parent / summary["video"]))
    assert video.get(cv2.CAP_PROP_FRAME_COUNT) == 8
    model = np.array(summary["model_points_mm"])
    assert np.allclose(model, synth_head().landmarks_3d)
    posit = Posit(model)
    for record in records:
        ok, frame = video.read()
        assert ok and frame.shape == (240, 320, 3)
        R, T = np.array(record["R"]), np.array(record["T"])
        uv = np.array(record["landmarks"])
        assert np.allclose(uv, camera.project(model, R, T))
        assert np.allclose(record["intrinsics"]["camera_matrix"], camera.K)
        assert sum(record["visible"]) >= 40
        # The face is drawn where the landmarks are: the frame differs from the
        # background there (video compression blurs colours a little).
        px = np.round(uv).astype(int)
        diff = np.abs(frame[px[:, 1], px[:, 0]].astype(int) - 90).max(axis=1)
        assert np.mean(diff > 12) > 0.9
        est = posit.estimate(uv, camera)
        assert rotation_angle_deg(est.R, R) < 1.0
        assert record["rpy_deg"] == pytest.approx(rpy_from_rotation(R)._asdict())


def test_exact_landmarks_and_bad_folder(tmp_path: Path) -> None:
    camera = CameraIntrinsics.from_fov(640, 480, 60.0)
    poses = sweep_poses("roll", 5)
    lms = exact_landmarks(synth_head(), poses, camera)
    assert len(lms) == 5 and lms[0].shape == (68, 2)
    with pytest.raises(ValueError, match="not a complete synth sequence"):
        load_sequence(tmp_path)


def test_eval_pose_end_to_end_on_fits(lfpw_fit_model_path, capsys) -> None:
    import json

    from services.cli import main

    argv = [
        "eval",
        "pose",
        "--json",
        "--frames",
        "6",
        "--sweep",
        "yaw",
        "--noise",
        "1",
        "--fits",
        "--fit-model",
        str(lfpw_fit_model_path),
    ]
    assert main(argv) == 0
    report = json.loads(capsys.readouterr().out)
    fits = report["aam_fits"]
    assert fits["frames"] == 6
    assert fits["estimated"] + fits["missing"] + fits["unreliable"] + fits["failed"] == 6
    assert fits["estimated"] >= 3
    assert abs(fits["errors"]["distance_cm"]["mean"]) < 10
