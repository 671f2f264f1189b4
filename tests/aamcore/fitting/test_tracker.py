"""aamcore.fitting.tracker with the default method on real video: re-detection, bad input."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.fitting.tracker import Tracker
from aamcore.io.video import video_frames


@pytest.fixture(scope="module")
def faces(single_face: Path) -> list[np.ndarray]:
    return video_frames(single_face)


@pytest.fixture(scope="module")
def empty(no_face: Path) -> list[np.ndarray]:
    return [cv2.resize(f, (640, 360)) for f in video_frames(no_face)[::6]]


@pytest.fixture()
def tracker(model_path: Path) -> Tracker:
    return Tracker(Fitter(FittingModel.load(model_path)))


def test_tracks_with_one_detection(tracker: Tracker, faces) -> None:
    results = [tracker.track(f) for f in faces[:30]]
    assert all(r is not None and r.ok for r in results) and tracker.detections == 1
    assert all(r.c.shape == (0,) and 0 < r.confidence <= 1 for r in results)
    assert tracker.fitter.failure_test == "quality"


def test_a_face_that_leaves_and_comes_back_is_found_again(tracker: Tracker, faces,
                                                          empty) -> None:
    for frame in faces[:10]:
        assert tracker.track(frame).ok
    for frame in empty:  # no face: no result reported as good, whatever was tracked before
        result = tracker.track(frame)
        assert result is None or result.failed
    back = [tracker.track(f) for f in faces[10:15]]
    assert any(r is not None and r.ok for r in back)
    black = tracker.track(np.zeros_like(faces[0]))
    assert black is None or black.failed


def test_a_frame_of_another_size_starts_afresh(tracker: Tracker, faces) -> None:
    for frame in faces[:5]:
        tracker.track(frame)
    detections = tracker.detections
    small = cv2.resize(faces[5], (320, 180))
    result = tracker.track(small)
    assert tracker.detections == detections + 1
    assert result is None or np.all((result.points >= -50) & (result.points <= 400))
    result = tracker.track(faces[6])
    assert result is not None and result.ok and tracker.detections == detections + 2
    with pytest.raises(ValueError, match="not an image"):
        tracker.track(None)  # type: ignore[arg-type]


def test_a_face_partly_outside_the_frame(tracker: Tracker, faces) -> None:
    first = tracker.track(faces[0])
    assert first is not None and first.ok
    x_mid = int(first.points[:, 0].mean())
    width = faces[0].shape[1]
    for frame in faces[1:8]:  # moved left: the face's centre on the frame's left border
        moved = np.zeros_like(frame)
        moved[:, : width - x_mid] = frame[:, x_mid:]
        result = tracker.track(moved)
        assert result is None or np.all(np.isfinite(result.points))
        assert result is None or result.failed or abs(result.points[:, 0].mean()) < 80
    back = tracker.track(faces[8])
    assert back is not None and back.ok
