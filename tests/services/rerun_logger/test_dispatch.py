"""The stream logger routes every kind of message on the frame and capture timelines."""

from __future__ import annotations

import pytest

from aamcore.ar.glasses_mesh import mean_head_glasses
from aamcore.pose.head_model import openface68
from proto.golden import CAPTURE_NS, golden_messages
from services.rerun_logger import entities as ent
from services.rerun_logger.dispatch import StreamLogger

ENTITY_OF_KIND = {
    "frame": ent.VIDEO,
    "boxes": ent.BOXES,
    "fit": ent.LANDMARKS,
    "pose": ent.HEAD,
    "expression": ent.EXPRESSION_SERIES + "/happy",
    "overlay": ent.OVERLAY,
    "status": ent.STATUS_SERIES + "/fitter/frames_in",
}


def test_every_golden_message_is_logged_at_its_frame(new_recording, rrd_tools):
    read, verify = rrd_tools
    rec = new_recording()
    logger = StreamLogger(rec.stream, openface68(), glasses=mean_head_glasses())
    golden = golden_messages()
    for msg in golden.values():
        logger.log(msg)
    rec.close()
    verify(rec.rrd_path)
    content = read(rec.rrd_path)
    assert logger.counts == dict.fromkeys(golden, 1)
    for kind, entity in ENTITY_OF_KIND.items():
        rows = [r for r in content.rows["/" + entity] if not r["static"]]
        assert rows, f"nothing logged for {kind} on {entity}"
        assert {r["frame"] for r in rows} == {golden[kind].header.frame_index}
        assert {r["capture_time"] for r in rows} == {CAPTURE_NS}
    events = {r["TextLog:text"][0]: r["frame"] for r in content.rows["/" + ent.EVENTS]}
    assert events == {
        "end of stream after 43 frames: end_of_file": 42,
        "frame 42: expression happy": 42,
        "fitter is running": 999,
    }
    assert "/" + ent.HEAD_MODEL in content.entities
    assert {"/" + ent.GLASSES_FRAME, "/" + ent.GLASSES_LENSES} <= content.entities
    assert content.mono("/" + ent.LATENCY_SERIES + "/fit", "Scalars:scalars") == [5.0]


def test_a_real_sequence_is_logged_frame_by_frame(new_recording, rrd_tools, faces, messages_of):
    read, verify = rrd_tools
    rec = new_recording()
    logger = StreamLogger(rec.stream, openface68(), jpeg_quality=70)
    for i, face in enumerate(faces):
        for msg in messages_of(face, i):
            logger.log(msg)
    rec.close()
    verify(rec.rrd_path)
    content = read(rec.rrd_path)
    for entity, column in [
        (ent.VIDEO, "EncodedImage:blob"),
        (ent.LANDMARKS, "Points2D:positions"),
        (ent.BOXES, "Boxes2D:centers"),
        (ent.HEAD, "Transform3D:translation"),
        (ent.CAMERA, "Pinhole:image_from_camera"),
        (ent.OVERLAY, "EncodedImage:blob"),
        (ent.EXPRESSION_SERIES + "/neutral", "Scalars:scalars"),
        (ent.LATENCY_SERIES + "/overlay", "Scalars:scalars"),
    ]:
        assert content.frames("/" + entity, column) == [0, 1, 2], entity


def test_unknown_objects_are_refused(new_recording):
    logger = StreamLogger(new_recording().stream)
    with pytest.raises(TypeError, match="not a proto message"):
        logger.log(object())  # type: ignore[arg-type]
