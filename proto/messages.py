"""The message kinds: frozen dataclasses with a validated wire form.

Each kind declares its body fields with a spec (:mod:`proto.fields`,
:mod:`proto.arrays`); constructing a message validates every field, and
``to_dict`` / ``from_dict`` convert the body to and from its msgpack map
(fields in declaration order). Arrays are read-only when decoded; arrays given
to a constructor are converted to the wire dtype, copied only when needed.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field, fields
from typing import Any, ClassVar, Self

import msgpack
import numpy as np

from proto.arrays import ArraySpec
from proto.fields import Bool, Float, Int, Spec, Str, StrList, check_keys, type_name
from proto.header import Header
from proto.keys import check_name, status_key, topic_key
from proto.limits import (
    MAX_IMAGE_BYTES,
    MAX_IMAGE_HEIGHT,
    MAX_IMAGE_PIXELS,
    MAX_IMAGE_WIDTH,
    MAX_SMALL_ARRAY_BYTES,
    ProtoError,
)

ENCODINGS = ("raw", "jpeg")
WARP_PATHS = ("gpu", "cpu")
STATES = ("starting", "running", "waiting", "degraded", "stopping", "stopped", "failed")
"""Service states of ``Status.state``."""
JPEG_MAGIC = b"\xff\xd8\xff"


def spec(s: Spec) -> Any:
    """Declare a required body field validated by ``s``."""
    return field(metadata={"spec": s})


def small(dtype: str, *shape: int | None) -> Any:
    """Declare a small array field (at most ``MAX_SMALL_ARRAY_BYTES``, no NaN)."""
    return spec(ArraySpec(dtype, shape, MAX_SMALL_ARRAY_BYTES))


WIDTH = Int(1, MAX_IMAGE_WIDTH)
HEIGHT = Int(1, MAX_IMAGE_HEIGHT)
COUNT = Int()
NAME = Str(min_len=1)


@dataclass(frozen=True, eq=False)
class Message:
    """Base of every message kind: a header and the body fields of the subclass."""

    KIND: ClassVar[str] = ""
    header: Header

    def __post_init__(self) -> None:
        if not isinstance(self.header, Header):
            raise ProtoError(f"{self.KIND}.header: expected a Header, got {type_name(self.header)}")
        for name, s in self.specs().items():
            object.__setattr__(self, name, s.check(getattr(self, name), f"{self.KIND}.{name}"))
        self._check()

    def _check(self) -> None:
        """Rules that tie fields together; raise ``ProtoError``. Overridden by kinds."""

    @classmethod
    @functools.cache
    def specs(cls) -> dict[str, Spec]:
        """Body field name -> spec, in wire order."""
        return {f.name: f.metadata["spec"] for f in fields(cls) if "spec" in f.metadata}

    def key(self) -> str:
        """The Zenoh key this message is published on."""
        return topic_key(self.header.stream_id, self.KIND)

    def to_dict(self) -> dict[str, Any]:
        """The body as a msgpack-ready map (arrays as ``{"dtype", "shape", "data"}``)."""
        return {name: s.encode(getattr(self, name)) for name, s in self.specs().items()}

    @classmethod
    def from_dict(cls, body: Any, header: Header) -> Self:
        """Validate an unpacked body map and build the message.

        Raises
        ------
        ProtoError
            Naming the first field that does not fit.
        """
        if not isinstance(header, Header):
            raise ProtoError(f"{cls.KIND}.header: expected a Header, got {type_name(header)}")
        specs = cls.specs()
        check_keys(body, specs, cls.KIND)
        msg = object.__new__(cls)
        object.__setattr__(msg, "header", header)
        for name, s in specs.items():
            object.__setattr__(msg, name, s.decode(body[name], f"{cls.KIND}.{name}"))
        msg._check()
        return msg

    def __eq__(self, other: object) -> bool:
        # Wire equality: arrays compare by bytes, and a NaN equals itself.
        if type(other) is not type(self):
            return NotImplemented
        pack = functools.partial(msgpack.packb, use_bin_type=True)
        return self.header == other.header and pack(self.to_dict()) == pack(other.to_dict())

    __hash__ = None  # type: ignore[assignment]


@dataclass(frozen=True)
class ImageSpec:
    """An image: a ``uint8`` array ``(H, W, 3)`` or ``(H, W)``, or JPEG bytes."""

    max_bytes: int = MAX_IMAGE_BYTES

    def _array_spec(self, ndim: int) -> ArraySpec:
        return ArraySpec("u1", (None, None, 3) if ndim == 3 else (None, None), self.max_bytes)

    def _check_jpeg(self, data: bytes, name: str) -> bytes:
        if len(data) > self.max_bytes:
            raise ProtoError(f"{name}: {len(data)} bytes exceed the limit of {self.max_bytes}")
        if not data.startswith(JPEG_MAGIC):
            raise ProtoError(f"{name}: JPEG data must start with FF D8 FF")
        return data

    def check(self, value: Any, name: str) -> np.ndarray | bytes:
        if isinstance(value, bytes):
            return self._check_jpeg(value, name)
        ndim = value.ndim if isinstance(value, np.ndarray) else 2
        return self._array_spec(ndim).check(value, name)

    def encode(self, value: np.ndarray | bytes) -> Any:
        return value if isinstance(value, bytes) else self._array_spec(value.ndim).encode(value)

    def decode(self, obj: Any, name: str) -> np.ndarray | bytes:
        if isinstance(obj, bytes):
            return self._check_jpeg(obj, name)
        shape = obj.get("shape") if isinstance(obj, dict) else None
        ndim = len(shape) if isinstance(shape, list) else 2
        return self._array_spec(ndim).decode(obj, name)


@dataclass(frozen=True, eq=False)
class _ImageMessage(Message):
    """A frame-sized image, raw or JPEG; base of ``Frame`` and ``Overlay``.

    Parameters
    ----------
    encoding : str
        ``"raw"``: ``image`` is a ``uint8`` array ``(height, width, 3)`` (BGR)
        or ``(height, width)`` (grey); ``"jpeg"``: ``image`` is JPEG bytes.
    width, height : int
        Image size in pixels (at most 4096 each and 4096 x 2160 in all).
    image : numpy.ndarray or bytes
        The pixels.
    """

    encoding: str = spec(Str(choices=ENCODINGS))
    width: int = spec(WIDTH)
    height: int = spec(HEIGHT)
    image: np.ndarray | bytes = spec(ImageSpec())

    def _check(self) -> None:
        if self.width * self.height > MAX_IMAGE_PIXELS:
            raise ProtoError(
                f"{self.KIND}: {self.width} x {self.height} exceeds {MAX_IMAGE_PIXELS} pixels"
            )
        is_raw = isinstance(self.image, np.ndarray)
        if is_raw != (self.encoding == "raw"):
            held = "an array" if is_raw else "bytes"
            raise ProtoError(f"{self.KIND}.image: encoding {self.encoding!r} but image is {held}")
        if is_raw and self.image.shape[:2] != (self.height, self.width):
            raise ProtoError(
                f"{self.KIND}.image: shape {list(self.image.shape)} does not match "
                f"height {self.height}, width {self.width}"
            )

    @classmethod
    def from_array(cls, header: Header, image: np.ndarray) -> Self:
        """A raw message from a ``uint8`` image ``(H, W, 3)`` or ``(H, W)``."""
        if not isinstance(image, np.ndarray) or image.ndim not in (2, 3):
            raise ProtoError(f"{cls.KIND}.image: expected a 2-D or 3-D array")
        height, width = image.shape[:2]
        return cls(header, "raw", width, height, image)

    @classmethod
    def from_jpeg(cls, header: Header, data: bytes, width: int, height: int) -> Self:
        """A JPEG message; ``width`` and ``height`` are those of the encoded image."""
        return cls(header, "jpeg", width, height, data)


@dataclass(frozen=True, eq=False)
class Frame(_ImageMessage):
    """A captured video frame (see ``_ImageMessage`` for the fields)."""

    KIND: ClassVar[str] = "frame"


@dataclass(frozen=True, eq=False)
class Overlay(_ImageMessage):
    """A frame with the tracking result drawn on it (see ``_ImageMessage``)."""

    KIND: ClassVar[str] = "overlay"


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
class Fit(Message):
    """The AAM fitted to a face in one frame.

    Parameters
    ----------
    scheme : str
        Landmark scheme name (e.g. ``"ibug68"``).
    landmarks : numpy.ndarray
        ``(N, 2)`` float32 landmark positions ``x, y`` in frame pixels.
    appearance : numpy.ndarray
        ``(k,)`` float32 combined appearance parameters ``c``.
    similarity : numpy.ndarray
        ``(4,)`` float32 ``a, b, tx, ty``: the 2D similarity
        ``x -> [[a, -b], [b, a]] x + (tx, ty)`` placing the model frame in the
        image (``a = s cos theta``, ``b = s sin theta``); ``(0,)`` without landmarks.
    image_width, image_height : int
        Size of the frame fitted, pixels.
    texture_error : float
        Mean squared texture residual, >= 0; NaN when it could not be computed.
    iterations : int
        Fitting iterations done.
    converged : bool
        Whether the fit met its convergence test.
    failed : bool
        Whether the failure test rejected the fit (the face is lost).
    failure_reason : str
        Why it failed; empty exactly when ``failed`` is false.
    warp_path : str
        ``"gpu"`` or ``"cpu"``: where the image warp ran.
    """

    KIND: ClassVar[str] = "fit"
    scheme: str = spec(NAME)
    landmarks: np.ndarray = small("f4", None, 2)
    appearance: np.ndarray = small("f4", None)
    similarity: np.ndarray = small("f4", None)
    image_width: int = spec(WIDTH)
    image_height: int = spec(HEIGHT)
    texture_error: float = spec(Float(0.0, math.inf, allow_nan=True))
    iterations: int = spec(COUNT)
    converged: bool = spec(Bool())
    failed: bool = spec(Bool())
    failure_reason: str = spec(Str())
    warp_path: str = spec(Str(choices=WARP_PATHS))

    def _check(self) -> None:
        if len(self.similarity) not in (0, 4):
            raise ProtoError(f"fit.similarity: {len(self.similarity)} values, expected 4 (or 0)")
        if self.failed != bool(self.failure_reason):
            raise ProtoError(
                "fit.failure_reason: must be non-empty exactly when failed is true "
                f"(failed={self.failed}, reason={self.failure_reason!r})"
            )


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
        Whether the estimate passed its own checks.
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

    def _check(self) -> None:
        k = self.intrinsics
        if not (k[0, 0] > 0 and k[1, 1] > 0 and (k[2] == (0.0, 0.0, 1.0)).all()):
            raise ProtoError("pose.intrinsics: need fx > 0, fy > 0 and last row 0 0 1")


@dataclass(frozen=True, eq=False)
class Expression(Message):
    """The facial expression recognised in one frame.

    Parameters
    ----------
    label : str
        The recognised class, one of ``class_names``.
    class_names : tuple of str
        All classes, distinct (a list on the wire).
    scores : numpy.ndarray
        ``(C,)`` float32 score of each class, in the order of ``class_names``.
    smoothed : bool
        Whether the label was smoothed over recent frames.
    """

    KIND: ClassVar[str] = "expression"
    label: str = spec(NAME)
    class_names: tuple[str, ...] = spec(StrList())
    scores: np.ndarray = small("f4", None)
    smoothed: bool = spec(Bool())

    def _check(self) -> None:
        if self.label not in self.class_names:
            raise ProtoError(f"expression.label: {self.label!r} is not in class_names")
        if len(self.scores) != len(self.class_names):
            raise ProtoError(
                f"expression.scores: {len(self.scores)} scores for {len(self.class_names)} classes"
            )


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
