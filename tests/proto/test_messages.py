"""Tests of the message kinds: round trips, cross-field rules, keys."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from proto.codec import decode, encode
from proto.golden import GREY_JPEG_8X8
from proto.header import Header
from proto.limits import ProtoError
from proto.messages import (
    MESSAGE_TYPES,
    EndOfStream,
    Expression,
    FaceBoxes,
    Fit,
    Frame,
    HeadPose,
    Message,
    Overlay,
    Status,
)

HEADER = Header("cam0", 7, 1_000, "tester", 2_000)


@pytest.mark.parametrize("kind", list(MESSAGE_TYPES))
def test_every_kind_round_trips_through_its_dict_and_the_codec(
    kind: str, golden: dict[str, Message]
) -> None:
    msg = golden[kind]
    cls = MESSAGE_TYPES[kind]
    body = msg.to_dict()
    assert list(body) == list(cls.specs())
    again = cls.from_dict(body, msg.header)
    assert type(again) is cls and again == msg
    decoded = decode(encode(msg), kind)
    assert type(decoded) is cls and decoded == msg and decoded.header == msg.header
    for name in cls.specs():
        mine, theirs = getattr(msg, name), getattr(decoded, name)
        if isinstance(mine, np.ndarray):
            assert mine.dtype == theirs.dtype and mine.shape == theirs.shape
            np.testing.assert_array_equal(mine, theirs)
        else:
            assert mine == theirs


def test_messages_are_frozen_and_compare_by_wire_content(golden: dict[str, Message]) -> None:
    fit = golden["fit"]
    with pytest.raises(dataclasses.FrozenInstanceError):
        fit.confidence = 0.5  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        fit.appearance.iterations = 3  # type: ignore[misc,union-attr]
    assert fit != dataclasses.replace(
        fit, appearance=dataclasses.replace(fit.appearance, iterations=8))
    moved = dataclasses.replace(fit, landmarks=fit.landmarks + 1)
    assert fit != moved
    failed = dataclasses.replace(fit, appearance=None, warp_path="none", failed=True,
                                 failure_reason="lost")
    assert failed == decode(encode(failed)) and decode(encode(failed)).appearance is None
    with pytest.raises(TypeError):
        hash(fit)


def test_keys_of_messages(golden: dict[str, Message]) -> None:
    assert golden["fit"].key() == "aamtrack/cam0/fit"
    assert golden["eos"].key() == "aamtrack/cam0/eos"
    assert golden["status"].key() == "aamtrack/cam0/status/fitter"


def test_frames_hold_colour_grey_or_jpeg_images() -> None:
    colour = Frame.from_array(HEADER, np.zeros((480, 640, 3), np.uint8))
    assert (colour.encoding, colour.width, colour.height) == ("raw", 640, 480)
    grey = decode(encode(Frame.from_array(HEADER, np.full((3, 5), 9, np.uint8))), "frame")
    assert grey.image.shape == (3, 5) and grey.width == 5
    jpeg = decode(encode(Overlay.from_jpeg(HEADER, GREY_JPEG_8X8, 8, 8)), "overlay")
    assert jpeg.image == GREY_JPEG_8X8 and jpeg.encoding == "jpeg"


@pytest.mark.parametrize(
    ("build", "reason"),
    [
        (lambda: Frame(HEADER, "raw", 4, 3, GREY_JPEG_8X8), "encoding 'raw' but image is bytes"),
        (lambda: Frame(HEADER, "jpeg", 4, 3, np.zeros((3, 4), np.uint8)), "image is an array"),
        (lambda: Frame(HEADER, "png", 4, 3, GREY_JPEG_8X8), "'png' is not one of"),
        (lambda: Frame(HEADER, "raw", 5, 3, np.zeros((3, 4), np.uint8)), "does not match height"),
        (lambda: Frame(HEADER, "raw", 4, 3, np.zeros((3, 4, 4), np.uint8)), r"\(\*, \*, 3\)"),
        (lambda: Frame(HEADER, "raw", 4, 3, np.zeros((3, 4))), "uint8 numpy array"),
        (lambda: Frame.from_jpeg(HEADER, b"\x89PNG", 4, 3), "must start with FF D8 FF"),
        (lambda: Frame.from_jpeg(HEADER, GREY_JPEG_8X8, 4096, 4096), "exceeds 8847360 pixels"),
        (lambda: Frame.from_jpeg(HEADER, GREY_JPEG_8X8, 0, 3), r"frame.width: 0 is outside"),
        (lambda: Frame.from_array(HEADER, np.zeros(3, np.uint8)), "2-D or 3-D"),
        (lambda: Frame("header", "jpeg", 8, 8, GREY_JPEG_8X8), "frame.header: expected a Header"),
    ],
)
def test_image_rules(build, reason: str) -> None:
    with pytest.raises(ProtoError, match=reason):
        build()


def test_face_boxes_rules() -> None:
    boxes = FaceBoxes(HEADER, 640, 480, [[1, 2, 3, 4]], [0.5])
    assert boxes.boxes.dtype == np.float32
    assert FaceBoxes(HEADER, 640, 480, np.zeros((0, 4)), np.zeros(0)).boxes.shape == (0, 4)
    with pytest.raises(ProtoError, match="2 scores for 1 boxes"):
        FaceBoxes(HEADER, 640, 480, [[1, 2, 3, 4]], [0.5, 0.1])
    with pytest.raises(ProtoError, match="must not be negative"):
        FaceBoxes(HEADER, 640, 480, [[1, 2, -3, 4]], [0.5])
    with pytest.raises(ProtoError, match=r"boxes.boxes: shape \[1, 3\]"):
        FaceBoxes(HEADER, 640, 480, [[1, 2, 3]], [0.5])


def test_fit_rules(golden: dict[str, Message]) -> None:
    fit = golden["fit"]
    assert isinstance(fit, Fit) and fit.landmarks.dtype == np.float32
    with pytest.raises(ProtoError, match="non-empty exactly when failed"):
        dataclasses.replace(fit, failed=True)
    with pytest.raises(ProtoError, match="non-empty exactly when failed"):
        dataclasses.replace(fit, failure_reason="drifted")
    with pytest.raises(ProtoError, match="'fpga' is not one of"):
        dataclasses.replace(fit, warp_path="fpga")
    with pytest.raises(ProtoError, match="fit.appearance.texture_error: -1.0 is outside"):
        dataclasses.replace(fit.appearance, texture_error=-1.0)
    with pytest.raises(ProtoError, match="fit.appearance.texture_error: NaN is not allowed"):
        dataclasses.replace(fit.appearance, texture_error=math.nan)
    with pytest.raises(ProtoError, match="an appearance needs landmarks and a warp_path"):
        dataclasses.replace(fit, warp_path="none")
    with pytest.raises(ProtoError, match="an appearance needs landmarks"):
        dataclasses.replace(fit, landmarks=np.zeros((0, 2)))
    with pytest.raises(ProtoError, match="3 flags for 68 landmarks"):
        dataclasses.replace(fit, appearance=dataclasses.replace(
            fit.appearance, occluded=np.ones(3, np.uint8)))
    with pytest.raises(ProtoError, match="occluded: values must be 0 or 1"):
        dataclasses.replace(fit.appearance, occluded=np.full(68, 2, np.uint8))
    with pytest.raises(ProtoError, match="expected FitAppearance or None"):
        dataclasses.replace(fit, appearance={"c": [1.0]})
    assert dataclasses.replace(fit, appearance=None).c is None
    np.testing.assert_array_equal(fit.c, fit.appearance.c)
    with pytest.raises(ProtoError, match="fit.landmarks: 1 NaN"):
        dataclasses.replace(fit, landmarks=np.where(np.eye(68, 2, k=1) > 0, np.nan, fit.landmarks))


def test_head_pose_rules(golden: dict[str, Message]) -> None:
    pose = golden["pose"]
    with pytest.raises(ProtoError, match="pose.yaw_deg: 200.0 is outside"):
        dataclasses.replace(pose, yaw_deg=200.0)
    with pytest.raises(ProtoError, match="last row 0 0 1"):
        dataclasses.replace(pose, intrinsics=np.eye(3) * 2)
    with pytest.raises(ProtoError, match=r"pose.rotation: shape \[2, 2\]"):
        dataclasses.replace(pose, rotation=np.eye(2))
    assert isinstance(pose, HeadPose) and pose.rotation.dtype == np.float64


def test_expression_rules() -> None:
    names = ["neutral", "happy"]
    ok = Expression(HEADER, "happy", names, [0.25, 0.75], smoothed=False, reason="")
    assert ok.class_names == ("neutral", "happy")
    with pytest.raises(ProtoError, match="'sad' is not in class_names"):
        Expression(HEADER, "sad", names, [0.25, 0.75], smoothed=False, reason="")
    with pytest.raises(ProtoError, match="1 scores for 2 classes"):
        Expression(HEADER, "happy", names, [1.0], smoothed=False, reason="")
    with pytest.raises(ProtoError, match="distinct"):
        Expression(HEADER, "happy", ["happy", "happy"], [0.25, 0.75], smoothed=False, reason="")
    with pytest.raises(ProtoError, match="probabilities sum to 1.5000, not 1"):
        Expression(HEADER, "happy", names, [0.75, 0.75], smoothed=False, reason="")
    # A frame without a label: no scores, and the reason; never one without the other.
    none = Expression(HEADER, "", names, [], smoothed=False, reason="no face")
    assert none.label == "" and len(none.scores) == 0
    assert decode(encode(none), "expression").reason == "no face"
    with pytest.raises(ProtoError, match="non-empty exactly when label is empty"):
        Expression(HEADER, "", names, [], smoothed=False, reason="")
    with pytest.raises(ProtoError, match="non-empty exactly when label is empty"):
        Expression(HEADER, "happy", names, [0.25, 0.75], smoothed=False, reason="no face")
    with pytest.raises(ProtoError, match="without a label has no scores"):
        Expression(HEADER, "", names, [0.25, 0.75], smoothed=False, reason="no face")


def test_status_and_end_of_stream_rules(golden: dict[str, Message]) -> None:
    status = golden["status"]
    assert math.isnan(dataclasses.replace(status, latency_p50_ms=math.nan).latency_p50_ms)
    with pytest.raises(ProtoError, match="'dancing' is not one of"):
        dataclasses.replace(status, state="dancing")
    with pytest.raises(ProtoError, match="status.dropped: -1 is outside"):
        dataclasses.replace(status, dropped=-1)
    with pytest.raises(ProtoError, match="status.service"):
        dataclasses.replace(status, service="fit/ter")
    assert isinstance(status, Status)
    with pytest.raises(ProtoError, match=r"eos.reason: string of 0 bytes"):
        EndOfStream(HEADER, total_frames=3, reason="")
