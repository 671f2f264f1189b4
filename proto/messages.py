"""The message kinds: frozen dataclasses with a validated wire form.

Each kind declares its body fields with a spec (:mod:`proto.fields`,
:mod:`proto.arrays`); constructing a message validates every field, and
``to_dict`` / ``from_dict`` convert the body to and from its msgpack map
(fields in declaration order). Arrays are read-only when decoded; arrays given
to a constructor are converted to the wire dtype, copied only when needed.
The image kinds, ``Frame`` and ``Overlay``, are defined in :mod:`proto.images`
and re-exported here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from proto.fields import Bool, Float, Int, Str, StrList
from proto.images import Frame, Overlay
from proto.keys import check_name, status_key
from proto.limits import ProtoError
from proto.message import COUNT, HEIGHT, NAME, WIDTH, Message, small, spec
from proto.record import Group, GroupSpec

WARP_PATHS = ("gpu", "cpu", "none")
"""Where a fit's texture warps ran; ``none`` when nothing was warped."""
MAX_FACES = 64
"""The most faces a frame's fits may count (``fit.faces``)."""
FACE_ID = Int(-1)
"""A face id: >= 0 for a tracked face, -1 for a frame's answer without one."""


def face_field(default: int) -> Any:
    """A body field with a Python default (the wire always carries it)."""
    return field(default=default, metadata={"spec": FACE_ID})


STATES = ("starting", "running", "waiting", "degraded", "stopping", "stopped", "failed")
"""Service states of ``Status.state``."""


@dataclass(frozen=True, eq=False)
class FaceBoxes(Message):
    """Faces found by the detector in one frame.

    Parameters
    ----------
    image_width, image_height : int
        Size of the frame the boxes refer to, in pixels.
    boxes : numpy.ndarray
        ``(K, 4)`` float32: ``x, y, w, h`` in pixels (top-left corner and size).
    scores : numpy.ndarray
        ``(K,)`` float32 detector confidences, one per box.
    """

    KIND: ClassVar[str] = "boxes"
    image_width: int = spec(WIDTH)
    image_height: int = spec(HEIGHT)
    boxes: np.ndarray = small("f4", None, 4)
    scores: np.ndarray = small("f4", None)

    def _check(self) -> None:
        if len(self.scores) != len(self.boxes):
            raise ProtoError(f"boxes.scores: {len(self.scores)} scores for {len(self.boxes)} boxes")
        if (self.boxes[:, 2:] < 0).any():
            raise ProtoError("boxes.boxes: width and height must not be negative")


@dataclass(frozen=True, eq=False)
class FitAppearance(Group):
    """The AAM's appearance of the face fitted (a ``fit``'s ``appearance``).

    Parameters
    ----------
    c : numpy.ndarray
        ``(k,)`` float32 combined appearance parameters ``c`` of the AAM.
    texture_residual : numpy.ndarray
        ``(H, W)`` float32 texture residual ``g_image - g_model(c)`` of each pixel of the
        model's reference frame (the shape-normalised face, row-major), in the units of
        the normalised texture; 0 outside the face's triangles.
    texture_error : float
        Mean squared texture residual, >= 0.
    iterations : int
        AAM iterations done (0: the appearance was projected at a landmark regressor's
        landmarks).
    converged : bool
        Whether the AAM met its convergence test (a projection counts as converged).
    occluded : numpy.ndarray
        ``(N,)`` uint8, one per landmark: 1 where the texture around it says the face is
        covered, else 0; ``(0,)`` when occlusion was not judged.
    """

    NAME: ClassVar[str] = "fit.appearance"
    c: np.ndarray = small("f4", None)
    texture_residual: np.ndarray = small("f4", None, None)
    texture_error: float = spec(Float(0.0, math.inf))
    iterations: int = spec(COUNT)
    converged: bool = spec(Bool())
    occluded: np.ndarray = small("u1", None)

    def _check(self) -> None:
        if (self.occluded > 1).any():
            raise ProtoError("fit.appearance.occluded: values must be 0 or 1")


@dataclass(frozen=True, eq=False)
class Fit(Message):
    """The landmarks fitted to a face in one frame, and the AAM's appearance of it.

    Parameters
    ----------
    scheme : str
        Landmark scheme name (e.g. ``"ibug68"``).
    landmarks : numpy.ndarray
        ``(N, 2)`` float32 landmark positions ``x, y`` in frame pixels.
    similarity : numpy.ndarray
        ``(4,)`` float32 ``a, b, tx, ty``: the 2D similarity
        ``x -> [[a, -b], [b, a]] x + (tx, ty)`` placing the model frame in the
        image (``a = s cos theta``, ``b = s sin theta``); ``(0,)`` without landmarks.
    image_width, image_height : int
        Size of the frame fitted, pixels.
    failed : bool
        Whether the failure test rejected the fit (the face is lost).
    failure_reason : str
        Why it failed; empty exactly when ``failed`` is false.
    confidence : float
        How much the fit looks like a face, 0 to 1 (0 without a face or for a failed fit).
    warp_path : str
        ``"gpu"`` or ``"cpu"``: where the fit's texture warps ran; ``"none"`` when nothing
        was warped (a landmark regressor's fit without an appearance).
    appearance : FitAppearance or None
        The AAM's appearance of the face (a map of the fields of ``FitAppearance``), or
        nil (None) when the fit has none: no face, a failed regressor fit, or a
        regressor's fit with the appearance turned off.
    face_id : int
        Which face: an id >= 0 that stays the same while the face is tracked (and when
        it is found again soon at the same place); -1 for a failed fit or no face.
    faces : int
        How many ``fit`` messages the frame has (one per face tracked; one, with
        ``face_id`` -1, when none is), from 1 to 64.
    """

    KIND: ClassVar[str] = "fit"
    scheme: str = spec(NAME)
    landmarks: np.ndarray = small("f4", None, 2)
    similarity: np.ndarray = small("f4", None)
    image_width: int = spec(WIDTH)
    image_height: int = spec(HEIGHT)
    failed: bool = spec(Bool())
    failure_reason: str = spec(Str())
    confidence: float = spec(Float(0.0, 1.0))
    warp_path: str = spec(Str(choices=WARP_PATHS))
    appearance: FitAppearance | None = spec(GroupSpec(FitAppearance))
    face_id: int = face_field(0)
    faces: int = field(default=1, metadata={"spec": Int(1, MAX_FACES)})

    def _check(self) -> None:
        if self.face_id < 0 and not self.failed:
            raise ProtoError("fit.face_id: a good fit has a face id >= 0")
        if len(self.similarity) not in (0, 4):
            raise ProtoError(f"fit.similarity: {len(self.similarity)} values, expected 4 (or 0)")
        if self.failed != bool(self.failure_reason):
            raise ProtoError(
                "fit.failure_reason: must be non-empty exactly when failed is true "
                f"(failed={self.failed}, reason={self.failure_reason!r})"
            )
        found = self.appearance
        if found is None:
            return
        if len(self.landmarks) == 0 or self.warp_path == "none":
            raise ProtoError("fit.appearance: an appearance needs landmarks and a warp_path "
                             f"other than 'none' (got {len(self.landmarks)} landmarks, "
                             f"warp_path {self.warp_path!r})")
        if len(found.occluded) not in (0, len(self.landmarks)):
            raise ProtoError(f"fit.appearance.occluded: {len(found.occluded)} flags for "
                             f"{len(self.landmarks)} landmarks (expected one each, or none)")

    @property
    def c(self) -> np.ndarray | None:
        """The appearance parameters ``c`` (k,), None without an appearance."""
        return None if self.appearance is None else self.appearance.c


@dataclass(frozen=True, eq=False)
class HeadPose(Message):
    """The head pose estimated from a fit.

    Parameters
    ----------
    rotation : numpy.ndarray
        ``(3, 3)`` float64 rotation from model to camera coordinates.
    translation_mm : numpy.ndarray
        ``(3,)`` float64 model origin in camera coordinates, millimetres.
    roll_deg, pitch_deg, yaw_deg : float
        The rotation as angles in degrees, each in [-180, 180].
    intrinsics : numpy.ndarray
        ``(3, 3)`` float64 camera matrix ``K`` (``fx, fy > 0``, last row ``0 0 1``).
    image_width, image_height : int
        Size of the image ``intrinsics`` refers to, pixels.
    intrinsics_source : str
        Where ``K`` came from (e.g. ``"calibration:cam0.yaml"``, ``"assumed:fov60"``).
    iterations : int
        Pose iterations done.
    reliable : bool
        Whether the estimate passed its own checks (and the fit it comes from did not fail).
    reason : str
        Why the pose is not reliable (e.g. the fit failed, a face in profile, landmarks
        outside the frame); empty exactly when ``reliable`` is true.
    angle_sd_deg : float
        Predicted standard deviation of the least certain of roll, pitch and yaw, degrees,
        >= 0; NaN when the estimator does not predict it.
    face_id : int
        The ``face_id`` of the fit it comes from.
    covered : numpy.ndarray
        ``(k, 2)`` float32 pixel positions of the fit's landmarks flagged occluded (a hand or
        an object in front of the face): the AR stage hides the glasses around them.
        ``(0, 2)`` when none is (or the fit has no occlusion flags).
    """

    KIND: ClassVar[str] = "pose"
    rotation: np.ndarray = small("f8", 3, 3)
    translation_mm: np.ndarray = small("f8", 3)
    roll_deg: float = spec(Float(-180.0, 180.0))
    pitch_deg: float = spec(Float(-180.0, 180.0))
    yaw_deg: float = spec(Float(-180.0, 180.0))
    intrinsics: np.ndarray = small("f8", 3, 3)
    image_width: int = spec(WIDTH)
    image_height: int = spec(HEIGHT)
    intrinsics_source: str = spec(NAME)
    iterations: int = spec(COUNT)
    reliable: bool = spec(Bool())
    reason: str = spec(Str())
    angle_sd_deg: float = spec(Float(0.0, math.inf, allow_nan=True))
    face_id: int = face_field(0)
    covered: np.ndarray = small("f4", None, 2, empty=True)

    def _check(self) -> None:
        k = self.intrinsics
        if not (k[0, 0] > 0 and k[1, 1] > 0 and (k[2] == (0.0, 0.0, 1.0)).all()):
            raise ProtoError("pose.intrinsics: need fx > 0, fy > 0 and last row 0 0 1")
        if self.reliable == bool(self.reason):
            raise ProtoError(
                "pose.reason: must be non-empty exactly when reliable is false "
                f"(reliable={self.reliable}, reason={self.reason!r})"
            )


@dataclass(frozen=True, eq=False)
class Expression(Message):
    """The facial expression recognised in one frame, or why there is none.

    Every fit gets one: a frame without a label (no face, a face the quality gate
    refuses, no classifier) has an empty ``label``, no ``scores`` and its ``reason``.

    Parameters
    ----------
    label : str
        The recognised class, one of ``class_names``; empty without one.
    class_names : tuple of str
        All classes, distinct (a list on the wire).
    scores : numpy.ndarray
        ``(C,)`` float32 probability of each class, in the order of ``class_names``,
        summing to 1 (calibrated on held-out faces); ``(0,)`` without a label.
    smoothed : bool
        Whether the label was smoothed or held over recent frames.
    reason : str
        Why there is no label, ``"<key>: <details>"``; empty exactly when there is one.
    face_id : int
        The ``face_id`` of the fit it comes from (each face has its own reference and
        smoothing).
    """

    KIND: ClassVar[str] = "expression"
    label: str = spec(Str())
    class_names: tuple[str, ...] = spec(StrList())
    scores: np.ndarray = small("f4", None)
    smoothed: bool = spec(Bool())
    reason: str = spec(Str())
    face_id: int = face_field(0)

    def _check(self) -> None:
        if bool(self.label) == bool(self.reason):
            raise ProtoError("expression.reason: must be non-empty exactly when label is empty "
                             f"(label={self.label!r}, reason={self.reason!r})")
        if not self.label:
            if len(self.scores):
                raise ProtoError("expression.scores: a frame without a label has no scores")
            return
        if self.label not in self.class_names:
            raise ProtoError(f"expression.label: {self.label!r} is not in class_names")
        if len(self.scores) != len(self.class_names):
            raise ProtoError(
                f"expression.scores: {len(self.scores)} scores for {len(self.class_names)} classes"
            )
        if not abs(float(np.sum(self.scores, dtype=np.float64)) - 1.0) <= 1e-3:
            raise ProtoError(f"expression.scores: probabilities sum to "
                             f"{float(np.sum(self.scores)):.4f}, not 1")


@dataclass(frozen=True, eq=False)
class Status(Message):
    """Health of one service, published periodically on ``.../status/<service>``.

    Parameters
    ----------
    service : str
        The service reported on; a key chunk.
    state : str
        One of :data:`STATES`.
    frames_in, frames_out, dropped, rejected : int
        Counts since the service started: messages received, published,
        dropped by design (e.g. stale frames skipped), rejected (invalid).
    lost : int
        Frames that never arrived: gaps in the frame numbering of its run.
    ignored : int
        Valid messages from outside the run (another run or a producer that
        does not own the key), not acted on.
    failed : int
        Valid messages taken that the service could not answer (an error while
        working on them).
    latency_p50_ms, latency_p99_ms : float
        Median and 99th percentile processing latency in milliseconds over a
        recent window; NaN before any frame.
    restarts : int
        How many times the service was restarted.
    message : str
        Free text, e.g. the last error; may be empty.
    """

    KIND: ClassVar[str] = "status"
    service: str = spec(Str(validate=check_name))
    state: str = spec(Str(choices=STATES))
    frames_in: int = spec(COUNT)
    frames_out: int = spec(COUNT)
    dropped: int = spec(COUNT)
    rejected: int = spec(COUNT)
    lost: int = spec(COUNT)
    ignored: int = spec(COUNT)
    failed: int = spec(COUNT)
    latency_p50_ms: float = spec(Float(0.0, math.inf, allow_nan=True))
    latency_p99_ms: float = spec(Float(0.0, math.inf, allow_nan=True))
    restarts: int = spec(COUNT)
    message: str = spec(Str())

    def key(self) -> str:
        return status_key(self.header.stream_id, self.service)


@dataclass(frozen=True, eq=False)
class EndOfStream(Message):
    """The last message of a stream.

    Parameters
    ----------
    total_frames : int
        Frames published on the stream.
    reason : str
        Why it ended, e.g. ``"end_of_file"``, ``"stopped"``, ``"error: ..."``.
    """

    KIND: ClassVar[str] = "eos"
    total_frames: int = spec(COUNT)
    reason: str = spec(NAME)


MESSAGE_TYPES: dict[str, type[Message]] = {
    cls.KIND: cls
    for cls in (Frame, FaceBoxes, Fit, HeadPose, Expression, Overlay, Status, EndOfStream)
}
"""Message kind -> class."""
