"""aamcore.evaluation.pose_sweeps: rendered sweeps tracked by a real tracker, cached."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np
import pytest

from aamcore import FaceTracker
from aamcore.evaluation.pose_sweeps import (
    SweepSpec,
    pack_landmarks,
    sequence_sweeps,
    tracked_sweeps,
    unpack_landmarks,
)
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.synth.sequence import synthesize

CAM = CameraIntrinsics.from_fov(320, 240, 60.0)
SPECS = (SweepSpec("yaw60", "yaw", 4, 60.0), SweepSpec("distance", "distance", 3))


class CountingTracker:
    """The library's face tracker as ``track(frames) -> landmarks``, counting its calls."""

    def __init__(self, model_path: Path) -> None:
        self.tracker = FaceTracker(model=model_path, classifier=False,
                                   landmark_smoothing=False, pose_smoothing=False)
        self.calls = 0

    def __call__(self, frames: Iterable[np.ndarray]) -> list[np.ndarray | None]:
        self.calls += 1
        self.tracker.reset()
        return [r.landmarks if r.success else None for r in map(self.tracker.process, frames)]


def test_landmarks_pack_and_unpack() -> None:
    marks = [np.ones((68, 2)), None]
    packed = pack_landmarks(marks, 3)
    assert packed.shape == (3, 68, 2) and np.isnan(packed[1:]).all()
    back = unpack_landmarks(packed)
    assert np.array_equal(back[0], marks[0]) and back[1] is None and back[2] is None


def test_sweeps_are_rendered_tracked_and_cached(
    model_path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("AAMTRACK_CACHE", str(tmp_path))
    track = CountingTracker(model_path)
    first = tracked_sweeps(track, "aam-test", CAM, SPECS)
    assert track.calls == 2 and len(list((tmp_path / "pose_sweeps").glob("*.npz"))) == 2
    yaw = first[0]
    assert yaw.spec.name == "yaw60" and len(yaw.poses) == 4 and yaw.exact.shape == (4, 68, 2)
    assert len(yaw.landmarks) == 4 and yaw.visible.shape == (4, 68)
    assert not yaw.visible[1].all()  # at +60 deg some of the far side is hidden
    frontal = yaw.landmarks[0]
    assert frontal is not None and np.abs(frontal - yaw.exact[0]).mean() < 10.0
    again = tracked_sweeps(track, "aam-test", CAM, SPECS)
    assert track.calls == 2  # from the cache
    for a, b in zip(first, again, strict=True):
        assert [m is None for m in a.landmarks] == [m is None for m in b.landmarks]
        assert all(np.array_equal(x, y) for x, y in zip(a.landmarks, b.landmarks, strict=True)
                   if x is not None)
    exact_only = tracked_sweeps(None, "none", CAM, SPECS)
    assert exact_only[0].landmarks == [] and np.array_equal(exact_only[0].exact, yaw.exact)


def test_an_aamtrack_synth_folder_becomes_sweeps(
    model_path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("AAMTRACK_CACHE", str(tmp_path / "cache"))
    synthesize(tmp_path / "seq", 8, "all", CAM, max_angle_deg=60.0)
    track = CountingTracker(model_path)
    sweeps, camera = sequence_sweeps(tmp_path / "seq", track, "aam-test")
    assert [s.spec.name for s in sweeps] == ["seq-yaw60", "seq-pitch60", "seq-roll60",
                                             "seq-distance"]
    assert sum(len(s.poses) for s in sweeps) == 8 and camera.width == 320
    assert all(len(s.landmarks) == len(s.poses) for s in sweeps)
    sequence_sweeps(tmp_path / "seq", track, "aam-test")
    assert track.calls == 1
    with pytest.raises(ValueError, match="not a complete synth sequence"):
        sequence_sweeps(tmp_path, None, "none")
