"""aamcore.fitting.multi: several faces in one frame, each under its own id: faces of real
video, and held-out faces moving with their exact landmarks (:mod:`tests.aamcore.truth`)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.fitting.multi import MultiTracker, NewFaces, blanked, overlap
from aamcore.fitting.tracker import Tracker
from aamcore.io.video import video_frames
from aamcore.synth.motion import Sequence
from tests.aamcore.truth import SLOW, clip, right, wrong_but_good
from tests.expectations import GOOD_SHARE


@pytest.fixture(scope="module")
def faces(single_face: Path) -> list[np.ndarray]:
    return video_frames(single_face)


@pytest.fixture(scope="module")
def fitter(model_path: Path) -> Fitter:
    return Fitter(FittingModel.load(model_path))


def pair(left: np.ndarray | None, right: np.ndarray | None, like: np.ndarray) -> np.ndarray:
    """Two video frames side by side (a grey half where one is None)."""
    blank = np.full_like(like, 128)
    return np.hstack([blank if left is None else left, blank if right is None else right])


def ids_by_side(tracker: MultiTracker, frame: np.ndarray) -> dict[str, int]:
    """The id of the face tracked in each half of ``frame``."""
    half = frame.shape[1] / 2
    found, _ = tracker.track(frame)
    out: dict[str, int] = {}
    for face in found:
        side = "left" if face.fit.points[:, 0].mean() < half else "right"
        assert side not in out, "two faces tracked in one half"
        out[side] = face.face_id
    return out


def test_two_faces_are_tracked_under_two_ids_that_stay(fitter: Fitter, faces) -> None:
    tracker = MultiTracker(fitter, max_faces=4)
    seen = [ids_by_side(tracker, pair(faces[k], faces[k + 36], faces[0])) for k in range(30)]
    both = [s for s in seen if len(s) == 2]
    assert len(both) >= GOOD_SHARE * len(seen)
    assert len({s["left"] for s in both}) == 1 and len({s["right"] for s in both}) == 1
    assert both[0]["left"] != both[0]["right"]


def test_the_faces_are_fitted_as_the_one_face_tracker_fits_each(fitter: Fitter, faces) -> None:
    """Landmarks of a face among others come within a tenth of its width of the single
    tracker's on that face alone (their starts differ: one search for both)."""
    tracker, single = MultiTracker(fitter, max_faces=2), Tracker(fitter)
    width = faces[0].shape[1]
    gaps = []
    for k in range(20):
        found, _ = tracker.track(pair(faces[k], faces[k + 36], faces[0]))
        alone = single.track(faces[k + 36])
        right = [f.fit for f in found if f.fit.points[:, 0].mean() > width]
        if right and alone is not None and alone.ok:
            moved = right[0].points - (width, 0)
            gaps.append(np.linalg.norm(moved - alone.points, axis=1).mean()
                        / np.ptp(alone.points[:, 0]))
    assert len(gaps) >= GOOD_SHARE * 20 and np.median(gaps) < 0.1


def test_one_face_is_the_single_tracker_exactly(fitter: Fitter, faces) -> None:
    multi, single = MultiTracker(fitter, max_faces=1), Tracker(fitter)
    for frame in faces[:25]:
        found, failed = multi.track(frame)
        alone = single.track(frame)
        if alone is not None and alone.ok:
            assert len(found) == 1 and failed is None
            np.testing.assert_array_equal(found[0].fit.points, alone.points)
        else:
            assert found == [] and (failed is None) == (alone is None)
    assert multi.detections == single.detections


def test_a_newcomer_is_picked_up_at_the_search_rate(fitter: Fitter, faces) -> None:
    policy = NewFaces(every=4)
    tracker = MultiTracker(fitter, max_faces=3, new_faces=policy)
    first = [ids_by_side(tracker, pair(faces[k], None, faces[0])) for k in range(8)]
    assert all(set(s) == {"left"} for s in first[1:])
    later = [ids_by_side(tracker, pair(faces[k], faces[k + 30], faces[0])) for k in range(8, 30)]
    picked = next(i for i, s in enumerate(later) if "right" in s)
    assert picked <= 2 * policy.every  # upright and turned searches take turns
    assert all(s.get("left") == first[-1]["left"] for s in later)
    assert later[picked]["right"] != first[-1]["left"]


@pytest.fixture(scope="module")
def two(lfpw_dir: Path, moving_face: Sequence) -> tuple[Sequence, Sequence]:
    """Two held-out faces moving slowly, each with its exact landmarks."""
    return moving_face, clip(lfpw_dir, replace(SLOW, seed=12), index=9)


def right_by_side(tracker: MultiTracker, two: tuple[Sequence, Sequence], k: int,
                  left: bool = True, rightward: bool = True) -> dict[str, int]:
    """The id of each face of frame ``k`` of the two clips side by side (either left out:
    grey) whose fit lies on its face; a fit called good that lies off its face fails."""
    a, b = two
    frame = pair(a.frames[k] if left else None, b.frames[k] if rightward else None,
                 a.frames[0])
    half = frame.shape[1] / 2
    found, _ = tracker.track(frame)
    truths = {"left": a.landmarks[k], "right": b.landmarks[k] + [half, 0]}
    out: dict[str, int] = {}
    for face in found:
        side = "left" if face.fit.points[:, 0].mean() < half else "right"
        assert side not in out, "two faces tracked in one half"
        assert not wrong_but_good(face.fit, truths[side]), (k, side)
        if right(face.fit, truths[side]):
            out[side] = face.face_id
    return out


def test_a_face_found_again_soon_keeps_its_id_and_later_gets_a_new_one(fitter: Fitter,
                                                                          two) -> None:
    policy = NewFaces(every=1, regain_frames=6)
    tracker = MultiTracker(fitter, max_faces=2, new_faces=policy)
    for k in range(5):
        before = right_by_side(tracker, two, k)
    assert set(before) == {"left", "right"}
    for k in range(5, 8):  # the right face is gone for 3 frames
        right_by_side(tracker, two, k, rightward=False)
    back = [right_by_side(tracker, two, k) for k in range(8, 12)]
    assert back[0].get("right") == before["right"]  # searched every frame: found at once
    for k in range(12, 24):  # gone for longer than the regain window
        right_by_side(tracker, two, k, rightward=False)
    again = [right_by_side(tracker, two, k) for k in range(24, 30)]
    new = {s["right"] for s in again if "right" in s}
    assert new and before["right"] not in new and before["left"] not in new
    assert all(s.get("left") == before["left"] for s in again)


def test_bad_frames_lose_every_face_and_the_next_good_ones_find_them(fitter: Fitter,
                                                                      two) -> None:
    tracker = MultiTracker(fitter, max_faces=2)
    for k in range(3):
        right_by_side(tracker, two, k)
    assert tracker.track(np.zeros((200, 300, 3), np.uint8))[0] == []  # another size, black
    with pytest.raises(ValueError, match="not an image"):
        tracker.track(np.zeros((0, 0), np.uint8))
    seen = [right_by_side(tracker, two, k) for k in range(3, 12)]
    found = next(i for i, s in enumerate(seen) if len(s) == 2)
    assert found <= 2 and all(len(s) == 2 for s in seen[found:])  # both, right, and kept


def test_a_policy_that_cannot_work_is_refused(fitter: Fitter) -> None:
    with pytest.raises(ValueError, match="max_faces"):
        MultiTracker(fitter, max_faces=0)
    with pytest.raises(ValueError, match="every 0: must be a whole number from 1"):
        NewFaces(every=0)
    with pytest.raises(ValueError, match="overlap"):
        NewFaces(overlap=0.0)


def test_boxes_overlap_over_the_smaller_one_and_tracked_faces_are_blanked() -> None:
    assert overlap(np.array([0, 0, 10, 10]), np.array([5, 5, 7, 7])) == 1.0
    assert overlap(np.array([0, 0, 10, 10]), np.array([10, 0, 20, 10])) == 0.0
    assert overlap(np.array([0, 0, 10, 10]), np.array([5, 0, 15, 10])) == 0.5
    grey = np.arange(100 * 100, dtype=np.uint16).reshape(100, 100).astype(np.uint8)

    class Fit:
        points = np.array([[40.0, 40.0], [60.0, 60.0]])

    out = blanked(grey, [Fit()])  # type: ignore[list-item]
    assert (out[40:60, 40:60] == int(grey.mean())).all() and (out[0] == grey[0]).all()
    assert blanked(grey, []) is grey


def test_ids_are_kept_through_a_crossing(fitter: Fitter, lfpw_dir: Path) -> None:
    """Two held-out faces; the second passes in front of the first and back. Outside the
    crossing each face keeps the id it had before it."""
    from aamcore.io import load_annotated_folder
    from aamcore.io.splits import split
    from aamcore.synth.group import FacePath, group_scene

    _, test = split(load_annotated_folder(lfpw_dir).samples, "lfpw")
    end = 59
    paths = [FacePath(((0, 480, 270), (end, 470, 280))),
             FacePath(((0, 200, 290), (end * 0.45, 760, 280), (end, 200, 270)))]
    scene = group_scene([(test[k].load_image(), test[k].points) for k in (4, 9)], paths,
                        end + 1, seed=1)
    tracker = MultiTracker(fitter, max_faces=2)
    ids: list[list[int]] = [[], []]
    for k, frame in enumerate(scene.frames):
        found, _ = tracker.track(frame)
        for i in range(2):
            truth = scene.truths[k, i]
            if scene.crossing[k, i] or not scene.in_view[k, i]:
                continue
            near = [f.face_id for f in found if np.linalg.norm(
                f.fit.points.mean(axis=0) - truth.mean(axis=0)) < 0.5 * np.ptp(truth[:, 0])]
            ids[i] += near[:1]
    assert scene.crossing.any() and all(len(seen) >= 20 for seen in ids)
    assert len(set(ids[0])) == 1 and len(set(ids[1])) == 1 and ids[0][0] != ids[1][0], ids
