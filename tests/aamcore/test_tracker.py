"""aamcore.tracker: the one-call API on a real video, with the small model."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from aamcore import FaceResult, FaceTracker
from aamcore.expression import AAMMismatchError, ExpressionClassifier
from aamcore.synth.motion import Sequence
from tests.aamcore.truth import right_face
from tests.expectations import FRAMES, GOOD_SHARE, check_poses


@pytest.fixture(scope="module")
def results(model_path: Path, classifier_path: Path, single_face: Path) -> list[FaceResult]:
    """The defaults (smoothing, the stack's label hold) with the small classifier made for the
    model (the default profile's learns from every face of three sets: minutes, not for tests)."""
    return list(FaceTracker(model=model_path, classifier=classifier_path)
                .process_video(single_face))


def test_every_frame_of_a_face_video_has_landmarks_pose_and_expression(
    results: list[FaceResult],
) -> None:
    assert [r.frame_index for r in results] == list(range(72))
    assert np.allclose([r.timestamp for r in results], np.arange(72) / 30.0)
    good = [r for r in results if r.success]
    assert len(good) >= GOOD_SHARE * FRAMES
    for r in good:
        assert r.landmarks.shape == (68, 2) and 0.0 < r.confidence <= 1.0
        assert r.rotation is not None and r.translation_mm is not None
        if r.pose_reliable:
            assert 200 < r.translation_mm[2] < 2000 and abs(r.yaw_deg) < 45
    angles = np.array([[r.yaw_deg, r.pitch_deg, r.roll_deg] if r.pose_reliable
                       else [np.nan] * 3 for r in results])
    check_poses([r.pose_reliable for r in good], [r.reason for r in good], angles)
    # An expression from the first frame (the person-independent model decides while the
    # stream's reference is made), else the reason; probabilities that sum to 1.
    for r in results:
        if r.expression is None:
            assert r.expression_scores == {} and r.expression_reason, r
            assert not r.expression_reason.startswith("learning"), r
        else:
            assert r.expression in r.expression_scores and len(r.expression_scores) == 7
            assert np.isclose(sum(r.expression_scores.values()), 1.0, atol=1e-6)
            assert r.expression_reason == ""
    labelled = [r.frame_index for r in good if r.expression is not None]
    assert len(labelled) >= GOOD_SHARE * len(good) and labelled[0] - good[0].frame_index <= 2
    data = json.loads(json.dumps(results[3].to_dict()))
    assert data["frame"] == 3 and len(data["landmarks"]) == 68 and len(data["rotation"]) == 3
    assert (data["expression"] is None) == bool(data["expression_reason"])
    assert json.loads(json.dumps(results[-1].to_dict()))["expression"] == results[-1].expression


def test_a_classifier_made_for_other_fits_is_refused(model_path: Path, classifier_path: Path
                                                     ) -> None:
    made = ExpressionClassifier.load(classifier_path)
    other = replace(made, aam_fingerprint="0123456789abcdef")
    with pytest.raises(AAMMismatchError, match="made for the fits of model 0123456789abcdef by "
                       "local-binary, not for those of model [0-9a-f]{16} by local-binary"):
        FaceTracker(model=model_path, classifier=other)
    with pytest.raises(AAMMismatchError, match="by local-binary, not for those of model "
                       "[0-9a-f]{16} by fixed-jacobian"):
        FaceTracker(model=model_path, classifier=made, algorithm="fixed-jacobian")
    blank = FaceTracker(model=model_path, classifier=classifier_path).process(
        np.full((360, 640, 3), 90, np.uint8))
    assert blank.expression is None and blank.expression_reason == "no face"


def test_smoothing_reduces_the_frame_to_frame_jitter(
    model_path: Path, single_face: Path, results: list[FaceResult]
) -> None:
    raw = list(FaceTracker(model=model_path, classifier=False, landmark_smoothing=False,
                           pose_smoothing=False)
               .process_video(single_face))

    def jitter(rs: list[FaceResult]) -> float:
        return float(np.mean([np.linalg.norm(b.landmarks - a.landmarks, axis=1).mean()
                              for a, b in zip(rs, rs[1:], strict=False)
                              if a.success and b.success]))

    assert jitter(results) < 0.75 * jitter(raw)  # smoothed by default
    assert raw[0].expression is None and raw[0].expression_reason == ""  # none asked for


def test_good_fits_carry_occlusion_flags(results: list[FaceResult]) -> None:
    good = [r for r in results if r.success]
    assert good and all(r.occluded is not None and r.occluded.shape == (68,) for r in good)
    # a talking face in front of a webcam: most landmarks of most frames are in sight
    assert np.mean([r.occluded.mean() for r in good]) < 0.5
    assert all(r.occluded is None for r in results if not r.success)


def test_a_frame_without_a_face_and_a_bad_video(model_path: Path, classifier_path: Path,
                                                tmp_path: Path) -> None:
    tracker = FaceTracker(model=model_path, classifier=classifier_path)
    empty = tracker.process(np.full((360, 640, 3), 90, np.uint8), timestamp=1.5)
    assert not empty.success and empty.reason == "no face" and empty.landmarks.shape == (0, 2)
    assert empty.confidence == 0.0 and math.isnan(empty.yaw_deg) and empty.timestamp == 1.5
    assert empty.to_dict()["rotation"] is None and empty.expression_reason == "no face"
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(b"not a video")
    with pytest.raises(OSError, match="not a video"):
        next(tracker.process_video(bad))


def test_the_pose_estimator_can_be_chosen(
    model_path: Path, single_face: Path, results: list[FaceResult]
) -> None:
    from aamcore.io.video import video_frames
    from aamcore.settings import ConfigError

    posit = FaceTracker(model=model_path, classifier=False, pose_estimator="posit")
    assert posit.pose.estimator.method == "posit"
    assert FaceTracker(model=model_path, classifier=False).pose.estimator.method == "contour"
    both = 0
    for frame, contour in zip(video_frames(single_face)[:5], results[:5], strict=False):
        r = posit.process(frame)
        assert r.success and r.pose_reliable == (r.reason == "")
        if r.pose_reliable and contour.pose_reliable:
            both += 1
            assert abs(r.yaw_deg - contour.yaw_deg) < 10.0
    assert both >= 3
    with pytest.raises(ConfigError, match="pose_estimator 'eos': choose one of .* "
                                          r"\(pose stage\)"):
        FaceTracker(model=model_path, classifier=False, pose_estimator="eos")


def test_bad_frames_mid_stream_give_clear_results(model_path: Path, moving_face: Sequence
                                                  ) -> None:
    """On a held-out face moving with its exact landmarks (:mod:`tests.aamcore.truth`): right
    landmarks, a frame of another size and a black one mid-stream, right again soon after."""
    import cv2

    frames, truth = moving_face.frames, moving_face.landmarks
    tracker = FaceTracker(model=model_path, classifier=False)
    assert all(right_face(tracker.process(f), t) for f, t in zip(frames[:5], truth, strict=False))
    small = tracker.process(cv2.resize(frames[5], (320, 180)))  # another size: detected afresh
    assert small.landmarks.shape in ((0, 2), (68, 2)) and np.all(np.isfinite(small.landmarks))
    assert not small.success or right_face(small, truth[5] / 2)
    black = tracker.process(np.zeros_like(frames[6]))
    assert not black.success and black.confidence == 0.0 and not black.pose_reliable
    back = [tracker.process(f) for f in frames[7:12]]
    right = [right_face(r, t) for r, t in zip(back, truth[7:12], strict=True)]
    assert any(right[:3]) and all(right[right.index(True):])  # found again, and kept
    assert back[-1].expression is None


def test_each_face_of_a_frame_gets_its_own_result_pose_and_expression(
    model_path: Path, classifier_path: Path, single_face: Path, results: list[FaceResult],
) -> None:
    """Two real faces side by side: a result per face with its id, landmarks in its half,
    its own pose and expression; one face the single tracker's results exactly."""
    from aamcore.io.video import video_frames

    frames = video_frames(single_face)
    width = frames[0].shape[1]
    tracker = FaceTracker(model=model_path, classifier=classifier_path, max_faces=2)
    per_frame = [tracker.process_faces(np.hstack([frames[k], frames[k + 36]]), k / 30)
                 for k in range(24)]
    two = [faces for faces in per_frame if len(faces) == 2 and all(r.success for r in faces)]
    assert len(two) >= GOOD_SHARE * len(per_frame)
    for faces in two:
        assert [r.face_id for r in faces] == sorted({r.face_id for r in faces})
        assert all(r.face_id >= 0 and r.rotation is not None for r in faces)
        assert all(r.expression is not None or r.expression_reason for r in faces)
        sides = sorted(r.landmarks[:, 0].mean() > width for r in faces)
        assert sides == [False, True]
    assert len({tuple(r.face_id for r in faces) for faces in two}) == 1
    blank = tracker.process_faces(np.full((360, 1280, 3), 90, np.uint8))
    assert len(blank) == 1 and blank[0].face_id == -1 and not blank[0].success
    assert blank[0].reason == "no face" and json.loads(json.dumps(blank[0].to_dict()))[
        "face_id"] == -1
    one = FaceTracker(model=model_path, classifier=classifier_path)
    again = [one.process(f) for f in frames[:12]]
    for a, b in zip(again, results[:12], strict=True):
        np.testing.assert_array_equal(a.landmarks, b.landmarks)
        assert a.expression == b.expression and a.face_id == b.face_id
    assert {r.face_id for r in again if r.success} == {0}
