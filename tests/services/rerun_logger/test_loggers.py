"""Each logger, fed real messages, writes what it should into a real ``.rrd`` file."""

from __future__ import annotations

import dataclasses
import math

import cv2
import numpy as np
import pytest

from aamcore.ar.glasses_mesh import LENS_PARTS, mean_head_glasses
from aamcore.io import load_annotated_folder
from aamcore.io.landmarks import IBUG68
from aamcore.pose.head_model import openface68
from proto.golden import golden_messages
from proto.messages import EndOfStream, Fit
from services.rerun_logger import entities as ent
from services.rerun_logger.annotations import PART_COLOURS, PARTS, LandmarkClasses
from services.rerun_logger.loggers import (
    BoxesLogger,
    ExpressionLogger,
    FitLogger,
    ImageLogger,
    LatencyLogger,
    PoseLogger,
    StatusLogger,
)
from services.rerun_logger.series import SeriesWriter

LANDMARKS = "/" + ent.LANDMARKS
IBUG_FAILED = len(PARTS)
"""Class id of a failed iBUG fit when iBUG is the first scheme (its parts are 0 to 4)."""


def part_ids() -> list[int]:
    """The class id of each iBUG landmark of a good fit: its part's."""
    ids = [-1] * 68
    for k, part in enumerate(PARTS):
        for i in IBUG68.groups[part]:
            ids[i] = k
    return ids


def _finished(rec, rrd_tools):
    """The content of ``rec``'s file once closed, after ``rerun rrd verify`` passed on it."""
    read, verify = rrd_tools
    rec.close()
    verify(rec.rrd_path)
    return read(rec.rrd_path)


def _at(rec, index: int) -> None:
    rec.stream.set_time(ent.FRAME_TIMELINE, sequence=index)


def test_image_logger_compresses_raw_frames(new_recording, rrd_tools, faces, messages_of):
    rec = new_recording()
    logger = ImageLogger(rec.stream, ent.VIDEO, quality=90)
    frames = [messages_of(face, i)[0] for i, face in enumerate(faces)]
    for i, frame in enumerate(frames):
        _at(rec, i)
        logger.log(frame)
    content = _finished(rec, rrd_tools)
    entity = "/" + ent.VIDEO
    assert content.frames(entity, "EncodedImage:blob") == [0, 1, 2]
    assert content.values(entity, "EncodedImage:media_type") == [["image/jpeg"]] * 3
    for frame, blob in zip(frames, content.values(entity, "EncodedImage:blob"), strict=True):
        data = bytes(blob[0])
        assert data[:3] == b"\xff\xd8\xff"
        assert len(data) < frame.image.nbytes / 4
        decoded = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
        assert decoded.shape == frame.image.shape
        assert np.abs(decoded.astype(int) - frame.image).mean() < 4.0


def test_image_logger_logs_jpeg_bytes_unchanged(new_recording, rrd_tools, faces, messages_of):
    rec = new_recording()
    overlay = messages_of(faces[0], 0)[-1]
    _at(rec, 0)
    ImageLogger(rec.stream, ent.OVERLAY).log(overlay)
    content = _finished(rec, rrd_tools)
    assert bytes(content.values("/" + ent.OVERLAY, "EncodedImage:blob")[0][0]) == overlay.image
    assert content.values("/" + ent.OVERLAY, "EncodedImage:media_type") == [["image/jpeg"]]


def test_boxes_logger_logs_xywh_boxes_and_clears_on_none(new_recording, rrd_tools):
    rec = new_recording()
    boxes = golden_messages()["boxes"]
    logger = BoxesLogger(rec.stream)
    _at(rec, 0)
    logger.log(boxes)
    _at(rec, 1)
    none = type(boxes)(boxes.header, image_width=640, image_height=480,
                       boxes=np.zeros((0, 4)), scores=np.zeros(0))
    logger.log(none)
    content = _finished(rec, rrd_tools)
    entity = "/" + ent.BOXES
    centers, empty = content.values(entity, "Boxes2D:centers")
    xywh = np.asarray(boxes.boxes, dtype=float)
    np.testing.assert_allclose(centers, xywh[:, :2] + xywh[:, 2:] / 2)
    np.testing.assert_allclose(content.values(entity, "Boxes2D:half_sizes")[0], xywh[:, 2:] / 2)
    assert content.values(entity, "Boxes2D:labels")[0] == ["face 0.88", "face 0.25"]
    assert empty == []


def test_fit_logger_logs_keypoints_of_the_scheme(new_recording, rrd_tools, faces, messages_of):
    rec = new_recording()
    logger = FitLogger(rec.stream, LandmarkClasses(), SeriesWriter(rec.stream))
    fits = [messages_of(face, i, failed=i == 2)[2] for i, face in enumerate(faces)]
    for i, fit in enumerate(fits):
        _at(rec, i)
        logger.log(fit)
    content = _finished(rec, rrd_tools)
    for fit, positions in zip(fits, content.values(LANDMARKS, "Points2D:positions"), strict=True):
        np.testing.assert_array_equal(np.asarray(positions, np.float32), fit.landmarks)
    assert content.values(LANDMARKS, "Points2D:keypoint_ids")[0] == list(range(68))
    # Good fits: each point in the class of its facial part; a failed fit: all in one class.
    assert content.values(LANDMARKS, "Points2D:class_ids") == [
        part_ids(), part_ids(), [IBUG_FAILED] * 68]
    (classes,) = content.static("/", "AnnotationContext:context")
    assert [c["class_id"] for c in classes] == list(range(len(PARTS) + 1))
    drawn = set()
    for k, part in enumerate(PARTS):
        desc = classes[k]["class_description"]
        assert desc["info"]["label"] == f"ibug68 (68 points) {part}"
        r, g, b = PART_COLOURS[part]
        assert desc["info"]["color"] == (r << 24) | (g << 16) | (b << 8) | 0xFF
        assert [a["id"] for a in desc["keypoint_annotations"]] == list(IBUG68.groups[part])
        assert {a["label"] for a in desc["keypoint_annotations"]} == {
            f"{part} {i}" for i in IBUG68.groups[part]}
        drawn |= {(e["keypoint0"], e["keypoint1"]) for e in desc["keypoint_connections"]}
    assert drawn == set(IBUG68.edges)
    failed = classes[IBUG_FAILED]["class_description"]
    assert "failed" in failed["info"]["label"]
    edges = {(k["keypoint0"], k["keypoint1"]) for k in failed["keypoint_connections"]}
    assert edges == set(IBUG68.edges)
    labels = [k["label"] for k in failed["keypoint_annotations"]]
    assert labels[::17] == ["jaw 0", "brows 17", "nose 34", "mouth 51"]
    series = "/" + ent.FIT_SERIES
    assert content.mono(f"{series}/failed", "Scalars:scalars") == [0.0, 0.0, 1.0]
    assert content.mono(f"{series}/iterations", "Scalars:scalars") == [5.0, 6.0, 7.0]
    np.testing.assert_allclose(content.mono(f"{series}/texture_error", "Scalars:scalars"),
                               [0.01, 0.02, 0.03])
    assert content.mono(f"{series}/occluded", "Scalars:scalars") == [0.0, 10.0, 20.0]
    assert [len(p) for p in content.values("/" + ent.OCCLUDED, "Points2D:positions")] == [
        0, 10, 20]
    assert len(content.values("/" + ent.RESIDUAL, "Image:buffer")) == 3
    (event,) = content.mono("/" + ent.EVENTS, "TextLog:text")
    assert "frame 2" in event and "texture error too large" in event


def test_fit_logger_clears_landmarks_when_no_face_is_found(new_recording, rrd_tools):
    rec = new_recording()
    logger = FitLogger(rec.stream, LandmarkClasses(), SeriesWriter(rec.stream))
    golden_fit = golden_messages()["fit"]
    _at(rec, 0)
    logger.log(golden_fit)
    no_face = Fit(golden_fit.header, **(golden_fit.to_dict() | {
        "landmarks": np.zeros((0, 2)), "appearance": None, "similarity": np.zeros(0),
        "warp_path": "none", "failed": True, "failure_reason": "no face",
    }))
    _at(rec, 1)
    logger.log(no_face)
    content = _finished(rec, rrd_tools)
    assert [len(p) for p in content.values(LANDMARKS, "Points2D:positions")] == [68, 0]
    (classes,) = content.static("/", "AnnotationContext:context")
    assert [c["class_id"] for c in classes] == list(range(len(PARTS) + 1))
    assert content.mono(f"/{ent.FIT_SERIES}/failed", "Scalars:scalars") == [0.0, 1.0]


def test_each_face_has_entities_of_its_own_and_a_face_gone_is_cleared(new_recording,
                                                                      rrd_tools):
    rec = new_recording()
    logger = FitLogger(rec.stream, LandmarkClasses(), SeriesWriter(rec.stream))
    golden_fit = golden_messages()["fit"]
    other = dataclasses.replace(golden_fit, landmarks=golden_fit.landmarks + 100.0, face_id=3,
                                faces=2)
    _at(rec, 0)
    logger.log(dataclasses.replace(golden_fit, faces=2))
    logger.log(other)
    _at(rec, 1)
    later = dataclasses.replace(golden_fit.header, frame_index=golden_fit.header.frame_index + 1)
    logger.log(dataclasses.replace(golden_fit, header=later))  # face 0 only: face 3 is cleared
    content = _finished(rec, rrd_tools)
    assert [len(p) for p in content.values(LANDMARKS, "Points2D:positions")] == [68, 68]
    third = content.values(f"/{ent.of_face(ent.LANDMARKS, 3)}", "Points2D:positions")
    assert len(third[0]) == 68 and np.allclose(third[0], golden_fit.landmarks + 100.0)
    assert len(content.rows[f"/{ent.of_face(ent.LANDMARKS, 3)}"]) == 2  # drawn, then cleared
    labels = content.values(f"/{ent.of_face(ent.FACE, 3)}", "Boxes2D:labels")
    assert labels[0] == ["face 3"]
    assert ent.of_face(ent.GLASSES_FRAME, 3) == "world/head_3/glasses/frame"
    assert ent.of_face(ent.LANDMARKS, -1) == ent.LANDMARKS


def test_fit_logger_draws_unknown_schemes_without_connections(new_recording, rrd_tools, imm_dir):
    imm = load_annotated_folder(imm_dir, limit=1).samples[0]
    rec = new_recording()
    logger = FitLogger(rec.stream, LandmarkClasses(), SeriesWriter(rec.stream))
    golden_fit = golden_messages()["fit"]
    _at(rec, 0)
    logger.log(golden_fit)
    imm_fit = Fit(golden_fit.header, scheme="imm73", landmarks=imm.points,
                  similarity=np.array([1.0, 0.0, 0.0, 0.0]), image_width=800, image_height=600,
                  failed=False, failure_reason="", confidence=0.9, warp_path="none",
                  appearance=None)
    _at(rec, 1)
    logger.log(imm_fit)
    content = _finished(rec, rrd_tools)
    imm_id = IBUG_FAILED + 1  # after iBUG's classes: its one part, "points"
    assert content.values(LANDMARKS, "Points2D:class_ids") == [part_ids(), [imm_id] * 73]
    (classes,) = content.static("/", "AnnotationContext:context")
    imm_class = next(c for c in classes if c["class_id"] == imm_id)["class_description"]
    assert imm_class["keypoint_connections"] == []
    assert len(imm_class["keypoint_annotations"]) == 73
    # No appearance: no texture error logged for that frame.
    assert content.frames("/" + ent.FIT_SERIES + "/texture_error", "Scalars:scalars") == [0]


def test_pose_logger_puts_the_head_model_where_the_landmarks_are(
    new_recording, rrd_tools, faces, messages_of
):
    rec = new_recording()
    model = openface68()
    logger = PoseLogger(rec.stream, LandmarkClasses(), SeriesWriter(rec.stream), model)
    poses = [messages_of(face, i)[3] for i, face in enumerate(faces)]
    for i, pose in enumerate(poses):
        _at(rec, i)
        logger.log(pose)
    content = _finished(rec, rrd_tools)
    head, camera = "/" + ent.HEAD, "/" + ent.CAMERA
    np.testing.assert_allclose(content.static("/" + ent.HEAD_MODEL, "Points3D:positions"),
                               model.points, rtol=1e-6, atol=1e-4)
    assert content.static("/" + ent.WORLD, "ViewCoordinates:xyz") is not None
    translations = content.mono(head, "Transform3D:translation")
    matrices = content.mono(head, "Transform3D:mat3x3")
    k_matrices = content.mono(camera, "Pinhole:image_from_camera")
    for face, pose, t, m, k in zip(faces, poses, translations, matrices, k_matrices, strict=True):
        # Rerun stores 3x3 matrices column-major.
        R = np.asarray(m, float).reshape(3, 3).T
        K = np.asarray(k, float).reshape(3, 3).T
        T = np.asarray(t, float)
        np.testing.assert_allclose(R, pose.rotation, atol=1e-6)
        np.testing.assert_allclose(K, pose.intrinsics, rtol=1e-6)
        np.testing.assert_allclose(T, pose.translation_mm, rtol=1e-5)
        # The logged transform maps the model into the camera so that it projects
        # onto the fitted landmarks (up to the generic model's error).
        cam = model.points @ R.T + T
        uv = cam[:, :2] / cam[:, 2:] * [K[0, 0], K[1, 1]] + K[:2, 2]
        error = np.linalg.norm(uv - face.points, axis=1).mean()
        assert error < 0.15 * IBUG68.inter_ocular(face.points)
    np.testing.assert_allclose(content.mono(camera, "Pinhole:image_plane_distance"),
                               [p.translation_mm[2] for p in poses], rtol=1e-5)
    yaw = content.mono("/" + ent.POSE_SERIES + "/yaw_deg", "Scalars:scalars")
    np.testing.assert_allclose(yaw, [p.yaw_deg for p in poses], rtol=1e-9)


def test_pose_logger_without_a_model(new_recording, rrd_tools):
    rec = new_recording()
    _at(rec, 0)
    PoseLogger(rec.stream, LandmarkClasses(), SeriesWriter(rec.stream)).log(
        golden_messages()["pose"]
    )
    content = _finished(rec, rrd_tools)
    assert "/" + ent.HEAD in content.entities
    assert "/" + ent.HEAD_MODEL not in content.entities


def test_expression_logger_logs_one_series_per_class(new_recording, rrd_tools, faces, messages_of):
    rec = new_recording()
    logger = ExpressionLogger(rec.stream, SeriesWriter(rec.stream))
    expressions = [messages_of(face, i)[4] for i, face in enumerate(faces)]
    for i, expression in enumerate(expressions):
        _at(rec, i)
        logger.log(expression)
    content = _finished(rec, rrd_tools)
    for c, name in enumerate(expressions[0].class_names):
        entity = f"/{ent.EXPRESSION_SERIES}/{name}"
        values = content.mono(entity, "Scalars:scalars")
        np.testing.assert_allclose(values, [e.scores[c] for e in expressions], rtol=1e-6)
        assert content.static(entity, "SeriesLines:names") == [name]
    labels = [e.label for e in expressions]
    changes = 1 + sum(a != b for a, b in zip(labels, labels[1:], strict=False))
    assert len(content.mono("/" + ent.EVENTS, "TextLog:text")) == changes


def test_a_frame_without_a_label_logs_its_reason_and_no_scores(new_recording, rrd_tools, faces,
                                                              messages_of):
    rec = new_recording()
    logger = ExpressionLogger(rec.stream, SeriesWriter(rec.stream))
    labelled = messages_of(faces[0], 0)[4]
    _at(rec, 0)
    logger.log(labelled)
    _at(rec, 1)
    logger.log(dataclasses.replace(labelled, label="", scores=np.zeros(0, np.float32),
                                   reason="face covered: 40 % of the inner landmarks occluded"))
    content = _finished(rec, rrd_tools)
    texts = content.mono("/" + ent.EVENTS, "TextLog:text")
    assert len(texts) == 2 and "no expression: face covered" in str(texts[-1])
    name = labelled.class_names[0]
    assert len(content.mono(f"/{ent.EXPRESSION_SERIES}/{name}", "Scalars:scalars")) == 1


def test_latency_logger_logs_each_stage_from_the_header(
    new_recording, rrd_tools, faces, messages_of
):
    rec = new_recording()
    series = SeriesWriter(rec.stream)
    logger = LatencyLogger(series)
    for i, face in enumerate(faces[:2]):
        _at(rec, i)
        for msg in messages_of(face, i):
            logger.log(msg)
    logger.log(golden_messages()["status"])
    logger.log(EndOfStream(golden_messages()["eos"].header, total_frames=2, reason="stopped"))
    content = _finished(rec, rrd_tools)
    latency = "/" + ent.LATENCY_SERIES
    assert {e for e in content.entities if e.startswith(latency)} == {
        f"{latency}/{kind}" for kind in ("frame", "boxes", "fit", "pose", "expression", "overlay")
    }
    np.testing.assert_allclose(content.mono(f"{latency}/fit", "Scalars:scalars"), [30.0, 31.0])
    assert content.static(f"{latency}/overlay", "SeriesLines:names") == ["capture -> overlay"]


def test_status_logger_logs_counts_and_state_changes(new_recording, rrd_tools):
    rec = new_recording()
    status = golden_messages()["status"]
    logger = StatusLogger(rec.stream, SeriesWriter(rec.stream))
    fields = {f: getattr(status, f) for f in ("frames_in", "rejected")}
    states = ["running", "running", "failed"]
    for i, state in enumerate(states):
        _at(rec, i)
        logger.log(type(status)(status.header, **(status.to_dict() | {
            "state": state, "frames_in": fields["frames_in"] + i,
            "latency_p50_ms": math.nan if i == 1 else 4.5, "message": "boom" if i == 2 else "",
        })))
    content = _finished(rec, rrd_tools)
    base = f"/{ent.STATUS_SERIES}/fitter"
    assert content.mono(f"{base}/frames_in", "Scalars:scalars") == [1000.0, 1001.0, 1002.0]
    assert content.mono(f"{base}/rejected", "Scalars:scalars") == [2.0] * 3
    assert content.frames(f"{base}/latency_p50_ms", "Scalars:scalars") == [0, 2]
    events = content.mono("/" + ent.EVENTS, "TextLog:text")
    assert events == ["fitter is running", "fitter is failed: boom"]
    assert content.mono("/" + ent.EVENTS, "TextLog:level") == ["INFO", "ERROR"]


@pytest.mark.parametrize("kind", ["fit", "pose"])
def test_loggers_share_one_annotation_context(new_recording, rrd_tools, kind):
    """The head model and the landmarks use the same iBUG class, logged once."""
    read, _ = rrd_tools
    rec = new_recording()
    classes, series = LandmarkClasses(), SeriesWriter(rec.stream)
    fit_logger = FitLogger(rec.stream, classes, series)
    pose_logger = PoseLogger(rec.stream, classes, series, openface68())
    first, second = (fit_logger, pose_logger) if kind == "fit" else (pose_logger, fit_logger)
    _at(rec, 0)
    first.log(golden_messages()["fit" if first is fit_logger else "pose"])
    second.log(golden_messages()["fit" if second is fit_logger else "pose"])
    rec.close()
    content = read(rec.rrd_path)
    (classes_logged,) = content.static("/", "AnnotationContext:context")
    assert [c["class_id"] for c in classes_logged] == list(range(len(PARTS) + 1))
    assert content.static("/" + ent.HEAD_MODEL, "Points3D:class_ids") == part_ids()


def test_pose_logger_puts_the_glasses_on_the_head_and_they_move_with_it(
    new_recording, rrd_tools, faces, messages_of
):
    rec = new_recording()
    glasses = mean_head_glasses()
    logger = PoseLogger(rec.stream, LandmarkClasses(), SeriesWriter(rec.stream), openface68(),
                        glasses)
    poses = [messages_of(face, i)[3] for i, face in enumerate(faces)]
    for i, pose in enumerate(poses):
        _at(rec, i)
        logger.log(pose)
    content = _finished(rec, rrd_tools)
    frame, lenses = "/" + ent.GLASSES_FRAME, "/" + ent.GLASSES_LENSES
    # Under the head's transform, logged once in the head model's frame.
    assert frame.startswith("/" + ent.HEAD + "/") and lenses.startswith("/" + ent.HEAD + "/")
    assert not [r for r in content.rows[frame] + content.rows[lenses] if not r["static"]]
    positions = np.vstack([content.static(e, "Mesh3D:vertex_positions") for e in (frame, lenses)])
    triangles = sum(len(content.static(e, "Mesh3D:triangle_indices")) for e in (frame, lenses))
    assert triangles == len(glasses.triangles)
    lens_vertices = np.vstack([glasses.part_vertices(n) for n in LENS_PARTS])
    logged_lenses = np.asarray(content.static(lenses, "Mesh3D:vertex_positions"))
    np.testing.assert_allclose(np.unique(logged_lenses, axis=0),
                               np.unique(lens_vertices, axis=0), atol=1e-4)
    used = np.unique(glasses.triangles)
    np.testing.assert_allclose(np.sort(positions, axis=0),
                               np.sort(glasses.vertices[used], axis=0), atol=1e-4)
    assert len(content.mono("/" + ent.HEAD, "Transform3D:translation")) == 3
    # The lenses sit in front of the eyes: in the camera, the posed lens centres project
    # near the eye centres the fit found.
    for face, pose in zip(faces, poses, strict=True):
        cam = glasses.lens_centres @ pose.rotation.T + pose.translation_mm
        K = pose.intrinsics
        uv = cam[:, :2] / cam[:, 2:] * [K[0, 0], K[1, 1]] + K[:2, 2]
        eyes = np.array([face.points[36:42].mean(axis=0), face.points[42:48].mean(axis=0)])
        assert np.linalg.norm(uv - eyes, axis=1).max() < 0.25 * IBUG68.inter_ocular(face.points)
