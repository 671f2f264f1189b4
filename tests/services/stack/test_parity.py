"""The stack and the library give the same results frame for frame: the services are
adapters around the library's operators, so the landmarks, poses and expressions of every
face of every frame agree within float tolerance (the messages carry float32), with one
face and with several."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from aamcore import FaceTracker
from aamcore.face_result import FaceResult
from services.stack.export import results_of
from services.stack.launcher import Stack
from services.stack.options import StackOptions, pipeline
from services.stack.recorder import load_messages
from tests.expectations import GOOD_SHARE


def run(stack_options: Callable[..., StackOptions], video: Path, rec: Path, **options: object
        ) -> tuple[dict[str, dict[tuple[int, int], Any]], StackOptions, dict]:
    """The fits, poses and expressions of a stack run on ``video`` by (frame, face), its
    options and summary. Fast pacing: the pose and expression services keep every fit; the
    CPU warp, as the library's (the GPU's bilinear weights differ by a fraction of a grey
    level, and so may an occlusion flag at its threshold)."""
    opts = stack_options(video, ar=False, record=str(rec), warp="cpu", **options)
    with Stack(opts) as stack:
        assert stack.wait() == "done"
        summary = stack.summary()
    messages = load_messages(rec)
    by_face = {kind: {(m.header.frame_index, m.face_id): m for m in messages if kind == m.KIND}
               for kind in ("fit", "pose", "expression")}
    return by_face, opts, summary


def assert_same(result: FaceResult, fit: Any, pose: Any, expression: Any, n_appearance: int
                ) -> None:
    """One face of one frame: the library's result and the stack's messages agree."""
    key = (result.frame_index, result.face_id)
    assert abs(result.timestamp - fit.header.media_time_ns / 1e9) < 1e-9, key
    assert result.success == (not fit.failed), key
    np.testing.assert_allclose(result.landmarks, fit.landmarks, atol=1e-3, err_msg=str(key))
    # Every good fit carries the AAM's appearance, and the same occlusion flags.
    assert (fit.appearance is not None) == result.success, key
    if result.success:
        assert fit.warp_path == "cpu" and len(fit.appearance.c) == n_appearance
        np.testing.assert_array_equal(fit.appearance.occluded.astype(bool), result.occluded)
    assert (pose is not None) == (result.rotation is not None), key
    if pose is not None:
        np.testing.assert_allclose(result.rotation, pose.rotation, atol=1e-5, err_msg=str(key))
        np.testing.assert_allclose(result.translation_mm, pose.translation_mm, atol=1e-2)
        assert result.pose_reliable == pose.reliable, key
    # The same labels, probabilities and reasons for the faces without a label.
    assert (result.expression or "") == expression.label, (key, result)
    if expression.label:
        np.testing.assert_allclose(  # the message's probabilities are float32
            [result.expression_scores[c] for c in expression.class_names],
            expression.scores, rtol=1e-6, atol=1e-5)
    else:
        assert result.expression_reason == expression.reason, key


def test_library_and_stack_agree_on_every_frame(
    single_face: Path, model_path: Path, classifier_path: Path, tmp_path: Path,
    stack_options: Callable[..., StackOptions],
) -> None:
    by_face, opts, summary = run(stack_options, single_face, tmp_path / "run.rec")
    fits, expressions = by_face["fit"], by_face["expression"]
    missing = sorted(set(range(72)) - {k for k, _ in fits})
    if missing:
        print(json.dumps(summary, indent=1, default=str))
    assert not missing, missing
    assert sorted(expressions) == sorted(fits)  # every fit answered, a label or why not
    # The stack smooths and holds expression labels by default, on the file's clock as the
    # library does: the same results however fast the run went. The library runs the
    # run's options tree (its model and classifier files named by the launcher's options).
    tracker = FaceTracker(pipeline(opts), model=model_path, classifier=classifier_path)
    n = tracker.model.aam.n_appearance
    for k, result in enumerate(tracker.process_video(single_face)):
        key = (k, result.face_id)
        assert_same(result, fits[key], by_face["pose"].get(key), expressions[key], n)
    labelled = [e for e in expressions.values() if e.label]
    assert len(labelled) >= GOOD_SHARE * sum(not f.failed for f in fits.values())


def test_library_and_stack_agree_on_every_face_of_every_frame(
    two_faces: Path, model_path: Path, classifier_path: Path, tmp_path: Path,
    stack_options: Callable[..., StackOptions],
) -> None:
    """Two real faces side by side through ``aamtrack run --max-faces 2``: the fits, poses
    and expressions of each face, by its id, as the library's ``process_faces``."""
    rec = tmp_path / "two.rec"
    by_face, opts, _ = run(stack_options, two_faces, rec, max_faces=2)
    tracker = FaceTracker(pipeline(opts), model=model_path, classifier=classifier_path)
    n, both = tracker.model.aam.n_appearance, 0
    for k, results in enumerate(tracker.process_video_faces(two_faces)):
        fits = [m for (i, _), m in by_face["fit"].items() if i == k]
        assert sorted(f.face_id for f in fits) == [r.face_id for r in results], k
        assert all(f.faces == len(results) for f in fits), k
        both += len(results) == 2 and all(r.success for r in results)
        for result in results:
            key = (k, result.face_id)
            assert_same(result, by_face["fit"][key], by_face["pose"].get(key),
                        by_face["expression"][key], n)
    assert both >= GOOD_SHARE * 20
    exported = results_of(load_messages(rec)).results  # aamtrack export: a row per face
    assert [(r.frame_index, r.face_id) for r in exported] == sorted(by_face["fit"])
    assert all(r.rotation is not None for r in exported if r.success and r.pose_reliable)
