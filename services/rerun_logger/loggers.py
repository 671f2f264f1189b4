"""One logger per kind of output, each taking decoded proto messages.

The loggers know nothing of the bus: they are given a ``rerun.RecordingStream``
and messages, and log at the stream's current time (the caller,
:class:`services.rerun_logger.dispatch.StreamLogger`, sets the timelines from
each message's header). Entity paths are in :mod:`services.rerun_logger.entities`.
"""

from __future__ import annotations

import numpy as np
import rerun as rr

from aamcore.annotate.palette import FACE_COLOURS, OCCLUDED_COLOUR
from aamcore.ar.glasses_mesh import LENS_PARTS, OPAQUE_PARTS, GlassesMesh
from aamcore.pose.head_model import HeadModel
from proto.keys import IMAGES, RESULTS
from proto.messages import Expression, FaceBoxes, Fit, Frame, HeadPose, Message, Overlay, Status
from services.rerun_logger import entities as ent
from services.rerun_logger.annotations import LandmarkClasses
from services.rerun_logger.images import DEFAULT_QUALITY, message_jpeg
from services.rerun_logger.series import SeriesWriter

BOX_COLOUR = (255, 200, 0)
RESIDUAL_SCALE = 80.0
"""Grey levels per unit of the texture residual |r| in the residual image (3 units: white)."""
HEAD_AXIS_MM = 60.0
"""Length of the head's drawn axes, millimetres."""
GLASSES_FRAME_COLOUR = (30, 30, 36)
"""The glasses' rims, bridge and temples, RGB: near-black, as the AR renderer draws them."""
GLASSES_LENS_COLOUR = (51, 89, 140, 110)
"""The glasses' lenses, RGBA: a translucent blue, as the AR renderer draws them."""
LATENCY_KINDS = (*IMAGES, *RESULTS)
"""Message kinds whose header latency (publish - capture) is a pipeline stage."""


def log_landmark_classes(
    rec: rr.RecordingStream, classes: LandmarkClasses, scheme: str, n_points: int, failed: bool
) -> np.ndarray:
    """The class id of each of a scheme's landmarks (its facial part's, or the failed class's),
    logging the annotation context when the scheme is new; ``(n_points,)``."""
    class_ids, is_new = classes.class_ids(scheme, n_points, failed)
    if is_new:
        rec.log("/", classes.context(), static=True)
    return class_ids


def glasses_meshes(glasses: GlassesMesh) -> dict[str, rr.Mesh3D]:
    """The glasses as two meshes, by entity: the frame (opaque parts) and the lenses."""
    meshes = {}
    for entity, names, colour in ((ent.GLASSES_FRAME, OPAQUE_PARTS, GLASSES_FRAME_COLOUR),
                                  (ent.GLASSES_LENSES, LENS_PARTS, GLASSES_LENS_COLOUR)):
        triangles = np.vstack([glasses.triangles[first:first + count]
                               for first, count in (glasses.parts[n] for n in names)])
        used, compact = np.unique(triangles, return_inverse=True)
        meshes[entity] = rr.Mesh3D(
            vertex_positions=glasses.vertices[used],
            vertex_normals=glasses.normals[used],
            triangle_indices=compact.reshape(-1, 3).astype(np.uint32),
            albedo_factor=colour,
        )
    return meshes


class ImageLogger:
    """Logs frame or overlay messages as JPEG ``EncodedImage`` on one entity.

    Parameters
    ----------
    rec : rerun.RecordingStream
    entity : str
        E.g. :data:`entities.VIDEO` or :data:`entities.OVERLAY`.
    quality : int
        JPEG quality for raw images (JPEG ones are logged as they came).
    """

    def __init__(self, rec: rr.RecordingStream, entity: str, quality: int = DEFAULT_QUALITY):
        self._rec = rec
        self._entity = entity
        self._quality = quality

    def log(self, msg: Frame | Overlay) -> None:
        """Log the image of ``msg``."""
        jpeg = message_jpeg(msg, self._quality)
        self._rec.log(self._entity, rr.EncodedImage(contents=jpeg, media_type="image/jpeg"))


class BoxesLogger:
    """Logs the detector's face boxes as ``Boxes2D`` labelled with their scores."""

    def __init__(self, rec: rr.RecordingStream) -> None:
        self._rec = rec

    def log(self, msg: FaceBoxes) -> None:
        """Log the boxes of ``msg`` (an empty batch clears the previous boxes)."""
        labels = [f"face {score:.2f}" for score in msg.scores]
        self._rec.log(
            ent.BOXES,
            rr.Boxes2D(
                array=np.asarray(msg.boxes, dtype=np.float32).reshape(-1, 4),
                array_format=rr.Box2DFormat.XYWH,
                labels=labels,
                colors=BOX_COLOUR,
            ),
        )


class FitLogger:
    """Logs fitted landmarks as keypoints of their scheme, and the fit quality as series.

    Landmarks go to :data:`entities.LANDMARKS`, each with the class of its
    facial part (coloured by part; a failed fit's all in the failed class of
    its scheme; a fit without landmarks clears them), the occluded ones again to
    :data:`entities.OCCLUDED` (magenta); the appearance's texture residual, as
    an image of ``|r|``, to :data:`entities.RESIDUAL`; texture error, iterations,
    the converged and failed flags and the number of occluded landmarks go to
    ``series/fit/*`` (the appearance's only for a fit with one); a failure is
    also a warning on :data:`entities.EVENTS`. Each face other than the first has
    entities of its own beside these (:func:`entities.of_face`); once all the fits of a
    frame have come, the landmarks of faces not among them are cleared.
    """

    def __init__(
        self, rec: rr.RecordingStream, classes: LandmarkClasses, series: SeriesWriter
    ) -> None:
        self._rec = rec
        self._classes = classes
        self._series = series
        self._shown: set[int] = set()
        self._frame: tuple[str, int] | None = None
        self._this: set[int] = set()

    def log(self, msg: Fit) -> None:
        """Log the landmarks and quality of ``msg``."""
        n = len(msg.landmarks)
        face = max(msg.face_id, 0)
        landmarks = ent.of_face(ent.LANDMARKS, face)
        if n == 0:  # no face: clear the previous landmarks
            self._rec.log(landmarks, rr.Points2D(np.zeros((0, 2), np.float32)))
            self._rec.log(ent.of_face(ent.FACE, face), rr.Clear(recursive=False))
        else:
            low, high = msg.landmarks.min(axis=0), msg.landmarks.max(axis=0)
            self._rec.log(ent.of_face(ent.FACE, face), rr.Boxes2D(
                mins=[low], sizes=[high - low], colors=[FACE_COLOURS[face % len(FACE_COLOURS)]],
                labels=[f"face {msg.face_id}" if msg.face_id >= 0 else "failed fit"]))
            class_ids = log_landmark_classes(self._rec, self._classes, msg.scheme, n, msg.failed)
            self._rec.log(
                landmarks,
                rr.Points2D(msg.landmarks, class_ids=class_ids, keypoint_ids=np.arange(n)),
            )
        self._log_appearance(msg, face)
        self._series.scalar(f"{ent.of_face(ent.FIT_SERIES, face)}/failed", float(msg.failed))
        self._clear_gone(msg, face)
        if msg.failed:
            self._rec.log(
                ent.EVENTS,
                rr.TextLog(
                    f"frame {msg.header.frame_index}: fit failed: {msg.failure_reason}",
                    level=rr.TextLogLevel.WARN,
                ),
            )

    def _clear_gone(self, msg: Fit, face: int) -> None:
        """Once a frame's fits have all come, clear the faces shown before but not in it."""
        key = (msg.header.run_id, msg.header.frame_index)
        if key != self._frame:
            self._frame, self._this = key, set()
        self._this.add(face)
        if len(self._this) < msg.faces:
            return
        for gone in self._shown - self._this:
            for path in (ent.LANDMARKS, ent.FACE, ent.OCCLUDED, ent.RESIDUAL):
                self._rec.log(ent.of_face(path, gone), rr.Clear(recursive=False))
        self._shown = set(self._this)

    def _log_appearance(self, msg: Fit, face: int) -> None:
        """The occluded landmarks, the residual image and the appearance's series (the
        occluded landmarks and the image cleared for a fit without an appearance)."""
        found = msg.appearance
        flags = found.occluded.astype(bool) if found is not None else np.zeros(0, bool)
        covered = msg.landmarks[flags] if len(flags) == len(msg.landmarks) else msg.landmarks[:0]
        self._rec.log(ent.of_face(ent.OCCLUDED, face),
                      rr.Points2D(covered, colors=OCCLUDED_COLOUR, radii=4.0))
        residual = ent.of_face(ent.RESIDUAL, face)
        if found is None:
            self._rec.log(residual, rr.Clear(recursive=False))
            return
        image = np.clip(np.abs(found.texture_residual) * RESIDUAL_SCALE, 0, 255)
        self._rec.log(residual, rr.Image(image.astype(np.uint8)))
        series = ent.of_face(ent.FIT_SERIES, face)
        self._series.scalar(f"{series}/texture_error", found.texture_error)
        self._series.scalar(f"{series}/iterations", found.iterations)
        self._series.scalar(f"{series}/converged", float(found.converged))
        self._series.scalar(f"{series}/occluded", float(flags.sum()))


class PoseLogger:
    """Logs the head pose as a 3D transform of the head model, and the camera as a pinhole.

    The world is the camera frame (OpenCV axes, mm). The pose's ``R, T`` map
    head-model to camera coordinates, which is exactly the transform of
    :data:`entities.HEAD` relative to :data:`entities.WORLD`. The head model's
    points are logged once, statically, under the head as keypoints of their
    scheme, so the annotation context draws the same parts and connections as
    on the video; so are the AR glasses, as meshes in the head model's frame
    (:data:`entities.GLASSES`), so that they move with the head. The
    pinhole's image plane is put at the head's depth, where the model's
    points project onto the fitted landmarks.

    Parameters
    ----------
    rec : rerun.RecordingStream
    classes : LandmarkClasses
        Shared with the :class:`FitLogger`.
    series : SeriesWriter
    head_model : HeadModel, optional
        3D points of a landmark scheme (e.g. ``aamcore.pose.head_model.openface68()``);
        ``None`` logs the pose without a model.
    glasses : GlassesMesh, optional
        The glasses in the head model's frame (e.g.
        ``aamcore.ar.glasses_mesh.mean_head_glasses()``); ``None`` draws none.
    """

    def __init__(
        self,
        rec: rr.RecordingStream,
        classes: LandmarkClasses,
        series: SeriesWriter,
        head_model: HeadModel | None = None,
        glasses: GlassesMesh | None = None,
    ) -> None:
        self._rec = rec
        self._classes = classes
        self._series = series
        self._head_model = head_model
        self._glasses = glasses
        self._static_logged: set[int] = set()
        """Faces whose head model and glasses are logged (under their head)."""

    def _log_static(self, face: int) -> None:
        if not self._static_logged:
            self._rec.log(ent.WORLD, rr.ViewCoordinates.RDF, static=True)
        self._rec.log(ent.of_face(ent.HEAD, face), rr.TransformAxes3D(HEAD_AXIS_MM),
                      static=True)
        model = self._head_model
        if model is not None:
            class_ids = log_landmark_classes(
                self._rec, self._classes, model.scheme, model.n_landmarks, failed=False
            )
            self._rec.log(
                ent.of_face(ent.HEAD_MODEL, face),
                rr.Points3D(model.points, class_ids=class_ids[model.indices],
                            keypoint_ids=model.indices),
                static=True,
            )
        if self._glasses is not None:
            for entity, mesh in glasses_meshes(self._glasses).items():
                self._rec.log(ent.of_face(entity, face), mesh, static=True)
        self._static_logged.add(face)

    def log(self, msg: HeadPose) -> None:
        """Log the camera, the head transform and roll, pitch, yaw of ``msg`` (each face's
        head and series apart, :func:`entities.of_face`)."""
        face = max(msg.face_id, 0)
        if face not in self._static_logged:
            self._log_static(face)
        depth = float(msg.translation_mm[2])
        self._rec.log(
            ent.CAMERA,
            rr.Pinhole(
                image_from_camera=msg.intrinsics,
                resolution=[msg.image_width, msg.image_height],
                camera_xyz=rr.ViewCoordinates.RDF,
                image_plane_distance=depth if depth > 0 else None,
            ),
        )
        self._rec.log(ent.of_face(ent.HEAD, face),
                      rr.Transform3D(translation=msg.translation_mm, mat3x3=msg.rotation))
        series = ent.of_face(ent.POSE_SERIES, face)
        for name in ("roll", "pitch", "yaw"):
            self._series.scalar(f"{series}/{name}_deg", getattr(msg, f"{name}_deg"))
        self._series.scalar(f"{series}/reliable", float(msg.reliable))


class ExpressionLogger:
    """Logs each class score as a series; a change of label is an event."""

    def __init__(self, rec: rr.RecordingStream, series: SeriesWriter) -> None:
        self._rec = rec
        self._series = series
        self._labels: dict[int, str] = {}

    def log(self, msg: Expression) -> None:
        """Log the probabilities of ``msg`` on ``series/expression/<class>`` (another face's on
        ``series/expression_<id>/<class>``); a frame without a label logs no series point
        (its reason ends the label shown)."""
        face = max(msg.face_id, 0)
        series = ent.of_face(ent.EXPRESSION_SERIES, face)
        for name, score in zip(msg.class_names if msg.label else (), msg.scores, strict=True):
            self._series.scalar(ent.child(series, name), float(score), name)
        if msg.label != self._labels.get(face):
            self._labels[face] = msg.label
            text = f"expression {msg.label}" if msg.label else f"no expression: {msg.reason}"
            who = f"face {face}: " if face > 0 else ""
            self._rec.log(ent.EVENTS,
                          rr.TextLog(f"frame {msg.header.frame_index}: {who}{text}"))


class LatencyLogger:
    """Logs the latency from capture to publication of each stage, in milliseconds."""

    def __init__(self, series: SeriesWriter) -> None:
        self._series = series

    def log(self, msg: Message) -> None:
        """Log ``publish_time_ns - capture_time_ns`` of ``msg`` on ``series/latency/<kind>``.

        Messages of kinds that are not a pipeline stage (status, end of stream)
        are ignored.
        """
        if msg.KIND not in LATENCY_KINDS:
            return
        ms = (msg.header.publish_time_ns - msg.header.capture_time_ns) / 1e6
        self._series.scalar(f"{ent.LATENCY_SERIES}/{msg.KIND}", ms, f"capture -> {msg.KIND}")


STATUS_COUNTS = (
    "frames_in",
    "frames_out",
    "dropped",
    "rejected",
    "restarts",
    "latency_p50_ms",
    "latency_p99_ms",
)
"""Status fields logged as series."""


class StatusLogger:
    """Logs each service's status counts as series; a change of state is an event."""

    def __init__(self, rec: rr.RecordingStream, series: SeriesWriter) -> None:
        self._rec = rec
        self._series = series
        self._states: dict[str, str] = {}

    def log(self, msg: Status) -> None:
        """Log the counts of ``msg`` on ``series/status/<service>/<field>``."""
        base = ent.child(ent.STATUS_SERIES, msg.service)
        for field in STATUS_COUNTS:
            self._series.scalar(f"{base}/{field}", getattr(msg, field), f"{msg.service} {field}")
        if self._states.get(msg.service) != msg.state:
            self._states[msg.service] = msg.state
            level = rr.TextLogLevel.ERROR if msg.state == "failed" else rr.TextLogLevel.INFO
            text = f"{msg.service} is {msg.state}" + (f": {msg.message}" if msg.message else "")
            self._rec.log(ent.EVENTS, rr.TextLog(text, level=level))
