"""The library and each service start from equal configurations: every default is defined
once (in aamcore: the tracker's in :class:`~aamcore.tracker_config.TrackerConfig`) and the
services' options wrap it, smoothing and the expression label hold included."""

from __future__ import annotations

import inspect

from aamcore import defaults
from aamcore.detection.haar import HaarFaceDetector
from aamcore.expression.recogniser import STACK_HOLD, ExpressionRecogniser
from aamcore.tracker import FaceTracker
from aamcore.tracker_config import TRACKER
from services.detector.options import DetectorOptions
from services.expression.options import ExpressionOptions
from services.fitter.options import FitterOptions
from services.pose.options import PoseOptions


def _default(function: object, name: str) -> object:
    return inspect.signature(function).parameters[name].default  # type: ignore[arg-type]


def test_the_fitter_service_and_the_library_fit_alike() -> None:
    assert FitterOptions().config() == TRACKER
    assert _default(FaceTracker, "config") is None  # None: TRACKER, the same object


def test_the_detector_service_and_the_library_search_alike() -> None:
    opts, haar = DetectorOptions(), HaarFaceDetector()
    assert (opts.scale_factor, opts.min_neighbors) == (haar.scale_factor, haar.min_neighbors)
    assert (opts.min_size, opts.min_size) == tuple(haar.min_size)
    assert opts.max_side == (haar.max_side or 0)
    assert defaults.DETECTOR["scale_factor"] == haar.scale_factor


def test_the_pose_service_and_the_library_estimate_alike() -> None:
    opts = PoseOptions()
    assert opts.estimator == defaults.POSE_ESTIMATOR and opts.fov == defaults.FOV_DEG
    assert _default(FaceTracker, "pose_estimator") is None  # None: defaults.POSE_ESTIMATOR


def test_the_expression_service_and_the_library_classify_alike_but_for_the_hold() -> None:
    opts = ExpressionOptions()
    assert opts.smooth == _default(FaceTracker, "expression_smooth") == _default(
        ExpressionRecogniser, "smooth")
    assert opts.hold == STACK_HOLD == TRACKER.expression_hold > 0  # the library's and the stack's
    assert PoseOptions().smooth == TRACKER.smoothing  # as smoothing


def test_one_limit_for_faces_from_the_tracker_to_the_wire() -> None:
    from proto import messages

    # proto may not import aamcore: the two constants are one limit, held equal here
    assert defaults.MAX_FACES == messages.MAX_FACES
    assert TRACKER.setting("max_faces").spec.high == defaults.MAX_FACES
