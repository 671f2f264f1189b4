"""The thesis's pipeline as a profile: ``aamtrack run --profile thesis`` end to end on a real
video, the library's ``FaceTracker(profile="thesis")`` giving the same results."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

from aamcore import FaceTracker
from aamcore.expression import ExpressionClassifier
from aamcore.expression.training import classifier_path as cached_classifier
from aamcore.profiles import profile_named
from services.stack.launcher import Stack, prepared
from services.stack.options import StackOptions
from services.stack.recorder import load_messages
from tests.expectations import FRAMES


@pytest.fixture(scope="module")
def thesis_classifier(model_path: Path) -> Path:
    """The thesis profile's classifier (LDA + Mahalanobis on c) for the fixed-Jacobian fits of
    the small model, trained on JAFFE on first use."""
    return cached_classifier(model_path, "fixed-jacobian", "thesis")


def test_the_thesis_profile_runs_end_to_end_and_the_library_agrees(
    single_face: Path, model_path: Path, thesis_classifier: Path, tmp_path: Path,
    stack_options: Callable[..., StackOptions],
) -> None:
    rec = tmp_path / "thesis.rec"
    opts = stack_options(single_face, ar=False, record=str(rec), warp="cpu", profile="thesis",
                         classifier=None)
    fitting, pose = opts.services["fitter"].fit.fitting, opts.services["pose"].pose
    assert (fitting.algorithm, fitting.failure_test, pose.estimator) == (
        "fixed-jacobian", "eq7.2", "posit")
    opts = prepared(opts)
    # the launcher found (or trained) the thesis classifier of these fits
    assert opts.services["expression"].expression.classifier == str(thesis_classifier)
    with Stack(opts) as stack:
        assert stack.wait() == "done"
        summary = stack.summary()
    assert summary["total_frames"] == FRAMES
    messages = load_messages(rec)
    fits = {m.header.frame_index: m for m in messages if m.KIND == "fit"}
    poses = {m.header.frame_index: m for m in messages if m.KIND == "pose"}
    expressions = {m.header.frame_index: m for m in messages if m.KIND == "expression"}
    assert sorted(fits) == list(range(FRAMES))  # every frame answered
    classifier = ExpressionClassifier.load(thesis_classifier)
    assert classifier.kind == "lda_mahalanobis"
    assert classifier.pipeline.features.blocks == ("appearance",)
    # Every fit with landmarks is an AAM fit: its appearance c, the AAM's iterations.
    with_face = [f for f in fits.values() if len(f.landmarks)]
    assert with_face and all(f.appearance is not None and f.warp_path == "cpu"
                             for f in with_face)
    assert max(f.appearance.iterations for f in with_face) >= 1
    tracker = FaceTracker(model=model_path, classifier=thesis_classifier, profile="thesis",
                          warp="cpu")
    assert profile_named("thesis").options.fit.fitting == tracker.options.fit.fitting
    # The services run on one BLAS thread: so does the library here, else the AAM's
    # iterations may differ in the last bits (0.004 px seen with two threads).
    with threadpool_limits(limits=1):
        results = list(tracker.process_video(single_face))
    assert all(e.label or e.reason for e in expressions.values())
    for k, result in enumerate(results):
        fit = fits[k]
        assert result.success == (not fit.failed), k
        np.testing.assert_allclose(result.landmarks, fit.landmarks, atol=1e-3, err_msg=str(k))
        if k in poses:
            np.testing.assert_allclose(result.rotation, poses[k].rotation, atol=1e-5)
        assert (result.expression or "") == expressions[k].label, k
        if not expressions[k].label:
            assert result.expression_reason == expressions[k].reason, k
