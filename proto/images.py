"""The image message kinds: ``Frame`` and ``Overlay``, raw pixels or JPEG.

Both share the body of :class:`_ImageMessage`, validated by :class:`ImageSpec`.
:mod:`proto.messages` re-exports ``Frame`` and ``Overlay`` and lists them in
``MESSAGE_TYPES``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, Self

import numpy as np

from proto.arrays import ArraySpec
from proto.fields import Str
from proto.header import Header
from proto.limits import MAX_IMAGE_BYTES, MAX_IMAGE_PIXELS, ProtoError
from proto.message import HEIGHT, WIDTH, Message, spec

ENCODINGS = ("raw", "jpeg")
JPEG_MAGIC = b"\xff\xd8\xff"


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
