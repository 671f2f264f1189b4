"""The library and each service start from equal options: every default is defined once (in
the options tree, :mod:`aamcore.operators.options`) and each service's options hold the
parts of its stage, smoothing and the expression label hold included."""

from __future__ import annotations

import inspect

from aamcore import defaults
from aamcore.detection.haar import HaarFaceDetector
from aamcore.expression.pipeline import LOST_FRAMES_RESET
from aamcore.expression.recogniser import STACK_HOLD
from aamcore.operators.options import PIPELINE, REFERENCE_RESET
from aamcore.tracker import FaceTracker
from services.ar.options import AROptions
from services.detector.options import DetectorOptions
from services.expression.options import ExpressionOptions
from services.fitter.options import FitterOptions
from services.pose.options import PoseOptions


def test_each_service_holds_the_parts_of_its_stage_as_the_library_has_them() -> None:
    assert FitterOptions().fit == PIPELINE.fit and FitterOptions().model == PIPELINE.model
    assert PoseOptions().pose == PIPELINE.pose
    assert ExpressionOptions().expression == PIPELINE.expression
    assert AROptions().overlay == PIPELINE.overlay
    assert DetectorOptions().detect == PIPELINE.detect
    assert inspect.signature(FaceTracker).parameters["options"].default is None  # the profile's


def test_the_detect_stage_searches_as_the_detector_does_by_default() -> None:
    opts, haar = PIPELINE.detect, HaarFaceDetector()
    assert (opts.scale_factor, opts.min_neighbors) == (haar.scale_factor, haar.min_neighbors)
    assert (opts.min_size, opts.min_size) == tuple(haar.min_size)
    assert opts.max_side == (haar.max_side or 0)
    assert defaults.DETECTOR["scale_factor"] == haar.scale_factor


def test_the_pose_and_expression_stages_use_the_library_defaults() -> None:
    assert PIPELINE.pose.estimator == defaults.POSE_ESTIMATOR
    assert PIPELINE.pose.fov == defaults.FOV_DEG
    assert PIPELINE.expression.hold == STACK_HOLD > 0
    assert REFERENCE_RESET == LOST_FRAMES_RESET  # options load light: the constant held equal


def test_one_limit_for_faces_from_the_tracker_to_the_wire() -> None:
    from proto import messages

    # proto may not import aamcore: the two constants are one limit, held equal here
    assert defaults.MAX_FACES == messages.MAX_FACES
    assert PIPELINE.setting("max_faces").spec.high == defaults.MAX_FACES
