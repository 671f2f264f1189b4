"""aamcore.annotate: a frame's results drawn on it (real frame, real EGL context) and written
as a video that OpenCV reads back."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from aamcore.annotate import AnnotatedVideo, Annotator, VideoWriter, video_output_problem
from aamcore.annotate.draw import face_lines
from aamcore.annotate.palette import OCCLUDED_COLOUR, PART_COLOURS, point_groups
from aamcore.ar.projection import project_points
from aamcore.face_result import FaceResult
from aamcore.io.landmarks import IBUG68
from aamcore.pose.head_model import openface68

W, H = 640, 480
K = np.array([[800.0, 0.0, 319.5], [0.0, 800.0, 239.5], [0.0, 0.0, 1.0]])
T = np.array([5.0, -10.0, 600.0])


@pytest.fixture(scope="module")
def frame(imm_set) -> np.ndarray:
    return cv2.resize(imm_set.samples[0].load_image(), (W, H))


@pytest.fixture(scope="module")
def annotator() -> Iterator[Annotator]:
    with Annotator() as made:  # module-scoped: its GL context is gone before other tests fork
        yield made


@pytest.fixture
def face() -> FaceResult:
    """The mean head seen straight on, its landmarks where the pose puts them."""
    points = project_points(openface68().points, np.eye(3), T, K)
    occluded = np.zeros(68, bool)
    occluded[[48, 54]] = True  # the mouth corners
    return FaceResult(0, 0.0, True, 0.9, points, rotation=np.eye(3), translation_mm=T,
                      pose_reliable=True, expression="HA",
                      expression_scores={"HA": 0.84, "NE": 0.16}, occluded=occluded,
                      face_id=3)


def test_landmarks_are_coloured_by_part_and_occluded_ones_ringed(
    annotator: Annotator, frame: np.ndarray, face: FaceResult
) -> None:
    before = frame.copy()
    out = annotator.draw(frame, [face], K)
    np.testing.assert_array_equal(frame, before)  # the frame is left alone
    groups = point_groups(IBUG68)
    for k in (8, 19, 30, 62):  # jaw, brow, nose, mouth: centres in their part's colour
        x, y = np.round(face.landmarks[k]).astype(int)
        expected = PART_COLOURS[groups[k]][::-1]
        assert np.abs(out[y, x].astype(int) - expected).max() <= 40, (k, groups[k], out[y, x])
    x, y = np.round(face.landmarks[48]).astype(int)
    ring = out[y - 8:y + 9, x - 8:x + 9].reshape(-1, 3).astype(int)
    magenta = np.array(OCCLUDED_COLOUR[::-1])
    assert (np.abs(ring - magenta).max(axis=1) <= 60).sum() >= 8


def test_glasses_are_drawn_at_a_reliable_pose_only(annotator: Annotator, frame: np.ndarray,
                                                   face: FaceResult) -> None:
    eyes = project_points(openface68().points[[36, 45]], np.eye(3), T, K)
    (x0, y0), (x1, y1) = np.round(eyes).astype(int)
    around = (slice(y0 - 30, y1 + 30), slice(x0 - 30, x1 + 30))  # both eyes: the lenses

    def changed(a: np.ndarray, b: np.ndarray) -> int:
        return int((np.abs(a[around].astype(int) - b[around].astype(int)).max(axis=2) > 40)
                   .sum())

    shown = annotator.draw(frame, [face], K)
    unsure = annotator.draw(frame, [replace(face, pose_reliable=False, reason="profile")], K)
    assert not annotator.glasses_problem
    assert changed(shown, unsure) > 200  # the rims and temples, a few pixels wide
    assert changed(unsure, frame) < changed(shown, frame) / 2  # the landmarks' drawing only


def test_labels_say_the_face_its_expression_or_why_there_is_none(face: FaceResult) -> None:
    assert face_lines(face) == ["face 3", "happy 84%"]
    learning = replace(face, expression=None, expression_scores={},
                       expression_reason="reference: learning the face's neutral reference")
    assert face_lines(learning)[1].startswith("no expression: reference: learning")
    failed = replace(face, success=False, reason="quality score 0.12 < 0.5")
    assert face_lines(failed)[0] == "face 3: fit failed (quality score 0.12 < 0.5)"
    none = FaceResult(5, 0.2, False, 0.0, np.zeros((0, 2)), reason="no face")
    assert face_lines(none) == ["no face"]
    unsure = replace(face, pose_reliable=False, reason="profile: yaw 70 deg")
    assert face_lines(unsure)[-1] == "pose unreliable: profile: yaw 70 deg"


def test_a_frame_without_a_face_says_so(frame: np.ndarray) -> None:
    none = FaceResult(5, 0.2, False, 0.0, np.zeros((0, 2)), reason="no face")
    with Annotator(glasses=False) as plain:
        out = plain.draw(frame, [none], None)
        empty = plain.draw(frame, [], None)
        assert not plain.glasses_problem
    corner = (slice(0, 40), slice(0, 120))
    assert np.abs(out[corner].astype(int) - frame[corner].astype(int)).max() > 80
    assert np.abs(empty[corner].astype(int) - frame[corner].astype(int)).max() > 80
    np.testing.assert_array_equal(out[H // 2:], frame[H // 2:])


def test_the_video_is_written_and_read_back(tmp_path: Path, frame: np.ndarray) -> None:
    for name in ("a.mp4", "a.avi"):
        with VideoWriter(tmp_path / name, 30.0) as writer:
            for _ in range(3):
                writer.write(frame)
        capture = cv2.VideoCapture(str(tmp_path / name))
        read = 0
        while capture.read()[0]:
            read += 1
        assert read == writer.frames == 3, name
    assert "write a .mp4 or .avi file (not .mkv)" in video_output_problem(tmp_path / "a.mkv")
    with pytest.raises(ValueError, match="not no suffix"):
        VideoWriter(tmp_path / "a", 30.0)
    with pytest.raises(OSError, match="cannot write"), \
            VideoWriter(tmp_path / "missing" / "a.mp4", 30.0) as writer:
        writer.write(frame)


def test_the_annotating_thread_writes_every_frame_in_order_and_hands_on_its_errors(
    tmp_path: Path, frame: np.ndarray, face: FaceResult
) -> None:
    """Frame k gets k + 1 faces' worth of drawing: the frames read back darken in order."""
    video = AnnotatedVideo(tmp_path / "a.avi", 30.0, glasses=False, backlog=2)
    for k in range(6):
        video.put(frame, [face] * (k % 2) + [replace(face, face_id=-1, landmarks=np.zeros(
            (0, 2)), reason="no face")] * (1 - k % 2), K)
    assert video.close() == 6 and not video.glasses_problem
    capture, labelled = cv2.VideoCapture(str(tmp_path / "a.avi")), []
    while (got := capture.read())[0]:
        corner = got[1][:30, :100].astype(int) - frame[:30, :100]
        labelled.append(bool(np.abs(corner).max() > 80))  # "no face" at the top left
    assert labelled == [True, False] * 3
    broken = AnnotatedVideo(tmp_path / "missing" / "a.mp4", 30.0, glasses=False)
    broken.put(frame, [], None)
    with pytest.raises(OSError, match="cannot write"):
        for _ in range(20):
            broken.put(frame, [], None)
        broken.close()
