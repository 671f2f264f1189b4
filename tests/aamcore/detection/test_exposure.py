"""aamcore.detection.exposure: a frame too dark to find a face in says so, in the fit's and
the expression's reasons; a frame lit as the clip is, or a dark one with a face found, does
not."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from aamcore.detection.exposure import DARK_LEVEL, darkness
from aamcore.io.video import video_frames
from aamcore.tracker import FaceTracker


def test_darkness_is_the_mean_grey_level_under_the_limit() -> None:
    assert darkness(np.full((360, 640, 3), 200, np.uint8)) == ""
    why = darkness(np.full((360, 640, 3), 12, np.uint8))
    assert why == (f"the frame is dark (mean grey level 12 of 255, at least {DARK_LEVEL:g} "
                   "to find a face)")
    assert darkness(np.full((360, 640), 12, np.uint8)) == why
    assert darkness(np.zeros((0, 0), np.uint8)) == "" and darkness(np.zeros(5)) == ""


def test_a_frame_too_dark_for_a_face_says_so(model_path: Path, classifier_path: Path,
                                             single_face: Path) -> None:
    frame = video_frames(single_face)[0]
    tracker = FaceTracker(model=model_path, classifier=classifier_path)
    lit = tracker.process_faces(frame, 0.0)[0]
    assert lit.success and "dark" not in lit.reason
    for level in (0.05, 0.0):
        tracker.reset()
        dark = tracker.process_faces((frame * level).astype(np.uint8), 0.0)[0]
        assert not dark.success and dark.reason.startswith("no face: the frame is dark")
        assert dark.expression is None and dark.expression_reason == dark.reason
    tracker.close()
