"""The Python API and the stack give the same landmarks, poses and expressions on the same
frames."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np

from aamcore import FaceTracker
from services.stack.export import results_of
from services.stack.launcher import Stack
from services.stack.options import StackOptions
from services.stack.recorder import load_messages
from tests.expectations import GOOD_SHARE


def test_library_and_stack_agree_on_every_frame(
    single_face: Path, model_path: Path, classifier_path: Path, tmp_path: Path,
    stack_options: Callable[..., StackOptions],
) -> None:
    rec = tmp_path / "run.rec"
    # fast pacing: the pose and expression services keep every fit (the fitter outruns them);
    # the CPU warp, as the library's (the GPU's bilinear weights differ by a fraction of a
    # grey level, and so may an occlusion flag at its threshold)
    with Stack(stack_options(single_face, ar=False, record=str(rec), warp="cpu")) as stack:
        assert stack.wait() == "done"
        summary = stack.summary()
    messages = load_messages(rec)
    fits = {m.header.frame_index: m for m in messages if m.KIND == "fit"}
    poses = {m.header.frame_index: m for m in messages if m.KIND == "pose"}
    expressions = {m.header.frame_index: m for m in messages if m.KIND == "expression"}
    missing = {k: sorted(set(range(72)) - set(d)) for k, d in (("fits", fits), ("poses", poses))}
    if any(missing.values()):
        print(json.dumps(summary, indent=1, default=str))
    assert not any(missing.values()), missing
    # The stack smooths and holds expression labels by default, on the file's clock as the
    # library does when asked: the same results however fast the run went.
    tracker = FaceTracker(model=model_path, classifier=classifier_path)  # the defaults agree
    assert sorted(expressions) == list(range(72))  # every fit answered, a label or why not
    for k, result in enumerate(tracker.process_video(single_face)):
        fit = fits[k]
        assert abs(result.timestamp - fit.header.media_time_ns / 1e9) < 1e-9
        assert result.success == (not fit.failed), k
        np.testing.assert_allclose(result.landmarks, fit.landmarks, atol=1e-3, err_msg=str(k))
        # Every good fit carries the AAM's appearance, and the same occlusion flags.
        assert (fit.appearance is not None) == result.success, k
        if result.success:
            assert fit.warp_path == "cpu"
            assert len(fit.appearance.c) == tracker.model.aam.n_appearance
            np.testing.assert_array_equal(fit.appearance.occluded.astype(bool), result.occluded)
        if k in poses:
            pose = poses[k]
            np.testing.assert_allclose(result.rotation, pose.rotation, atol=1e-5)
            np.testing.assert_allclose(result.translation_mm, pose.translation_mm, atol=1e-2)
            assert result.pose_reliable == pose.reliable
        # The same labels, probabilities and reasons for the frames without a label.
        expression = expressions[k]
        assert (result.expression or "") == expression.label, (k, result)
        if expression.label:
            np.testing.assert_allclose(  # the message's probabilities are float32
                [result.expression_scores[c] for c in expression.class_names],
                expression.scores, rtol=1e-6, atol=1e-5)
        else:
            assert result.expression_reason == expression.reason, k
    labelled = [e for e in expressions.values() if e.label]
    assert len(labelled) >= GOOD_SHARE * sum(not f.failed for f in fits.values())


def test_library_and_stack_agree_on_every_face_of_every_frame(
    two_faces: Path, model_path: Path, classifier_path: Path, tmp_path: Path,
    stack_options: Callable[..., StackOptions],
) -> None:
    """Two real faces side by side through ``aamtrack run --max-faces 2``: the fits, poses
    and expressions of each face, by its id, as the library's ``process_faces``."""
    two = two_faces
    rec = tmp_path / "two.rec"
    with Stack(stack_options(two, ar=False, record=str(rec), warp="cpu", max_faces=2)) as stack:
        assert stack.wait() == "done"
    messages = load_messages(rec)
    by_face = {kind: {(m.header.frame_index, m.face_id): m for m in messages if kind == m.KIND}
               for kind in ("fit", "pose", "expression")}
    tracker = FaceTracker(model=model_path, classifier=classifier_path, max_faces=2)
    both = 0
    for k, results in enumerate(tracker.process_video_faces(two)):
        fits = [m for (i, _), m in by_face["fit"].items() if i == k]
        assert sorted(f.face_id for f in fits) == [r.face_id for r in results], k
        assert all(f.faces == len(results) for f in fits), k
        both += len(results) == 2 and all(r.success for r in results)
        for result in results:
            key = (k, result.face_id)
            fit = by_face["fit"][key]
            np.testing.assert_allclose(result.landmarks, fit.landmarks, atol=1e-3,
                                       err_msg=str(key))
            if key in by_face["pose"]:
                np.testing.assert_allclose(result.rotation, by_face["pose"][key].rotation,
                                           atol=1e-5)
            assert (result.expression or "") == by_face["expression"][key].label, key
    assert both >= GOOD_SHARE * 20
    exported = results_of(messages).results  # aamtrack export: a row per face per frame
    assert [(r.frame_index, r.face_id) for r in exported] == [
        (m.header.frame_index, m.face_id) for m in messages if m.KIND == "fit"]
    assert all(r.rotation is not None for r in exported if r.success and r.pose_reliable)
