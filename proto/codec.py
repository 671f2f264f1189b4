"""Encode messages to msgpack payloads and decode payloads, validating everything.

A payload is the msgpack map ``{"header": {...}, "body": {...}}``; see
``proto/README.md`` for the full specification.
"""

from __future__ import annotations

import io
from typing import Any

import msgpack
import numpy as np

from proto.fields import check_keys, type_name
from proto.header import Header, read_kind
from proto.limits import (
    MAX_IMAGE_BYTES,
    MAX_IMAGE_PAYLOAD,
    MAX_LIST_LEN,
    MAX_MAP_LEN,
    MAX_SMALL_PAYLOAD,
    MAX_STR_LEN,
    ProtoError,
)
from proto.messages import MESSAGE_TYPES, Message

IMAGE_KINDS = ("frame", "overlay")
TOP_KEYS = ("header", "body")
Buffer = bytes | bytearray | memoryview
"""Bytes as they lie: a part of a payload."""
_EMPTY_BIN = b"\xc4\x00"


def payload_limit(kind: str | None) -> int:
    """Largest payload, in bytes, of a message of ``kind`` (``None``: of any kind)."""
    return MAX_IMAGE_PAYLOAD if kind is None or kind in IMAGE_KINDS else MAX_SMALL_PAYLOAD


def encode(msg: Message) -> bytes:
    """Encode a message as a msgpack payload.

    A valid message always fits its kind's payload limit: the field limits
    keep the largest message of each kind below it (the tests check this).
    """
    wire = {"header": msg.header.to_dict(msg.KIND), "body": msg.to_dict()}
    return msgpack.packb(wire, use_bin_type=True)


def encode_parts(msg: Message) -> list[Buffer]:
    """:func:`encode` in parts whose concatenation is the payload: an image message's pixels
    (or JPEG bytes), the payload's tail, are the last part, left where they lie (the
    ``bytes`` or ``bytearray`` an array views, else a view of the array), so that a sender
    copies them once, into shared memory or onto the network."""
    body = body_parts(msg)
    head = msgpack.packb({"header": msg.header.to_dict(msg.KIND), "body": None},
                         use_bin_type=True)[:-1]  # without the nil that stands for the body
    return [head + body[0], *body[1:]]


def body_parts(msg: Message) -> list[Buffer]:
    """The body map's bytes in parts: an image message's tail (its pixels or JPEG bytes)
    apart from the rest; any other kind in one part."""
    body = msg.to_dict()
    image = body.get("image") if msg.KIND in IMAGE_KINDS else None
    if image is None:
        return [msgpack.packb(body, use_bin_type=True)]
    if isinstance(image, dict):
        tail, body["image"] = image["data"], {**image, "data": b""}
    else:
        tail, body["image"] = image, b""
    packed = msgpack.packb(body, use_bin_type=True)
    assert packed.endswith(_EMPTY_BIN), "the image data is the body's last entry"
    data = _lying(tail, getattr(msg, "image", None))
    return [packed[:-len(_EMPTY_BIN)] + _bin_header(memoryview(data).nbytes), data]


def _bin_header(size: int) -> bytes:
    """msgpack's header of a bin of ``size`` bytes (the smallest format, as msgpack packs)."""
    if size < 1 << 8:
        return b"\xc4" + size.to_bytes(1, "big")
    if size < 1 << 16:
        return b"\xc5" + size.to_bytes(2, "big")
    return b"\xc6" + size.to_bytes(4, "big")


def _lying(data: Buffer, image: object) -> Buffer:
    """The bytes an image's data lies in: the ``bytes`` or ``bytearray`` a C-contiguous array
    views from its start to its end, else ``data`` itself."""
    if not isinstance(image, np.ndarray) or not image.flags.c_contiguous:
        return data
    owner = image
    while isinstance(owner, np.ndarray):
        owner = owner.base
    if isinstance(owner, memoryview):
        owner = owner.obj
    if (isinstance(owner, bytes | bytearray) and len(owner) == image.nbytes
            and np.frombuffer(owner, np.uint8).ctypes.data == image.ctypes.data):
        return owner
    return data


def _unpack(payload: bytes | bytearray | memoryview, limit: int) -> Any:
    try:
        return msgpack.unpackb(
            payload,
            raw=False,
            strict_map_key=True,
            use_list=True,
            max_bin_len=min(limit, MAX_IMAGE_BYTES),
            max_str_len=MAX_STR_LEN,
            max_array_len=MAX_LIST_LEN,
            max_map_len=MAX_MAP_LEN,
            max_ext_len=0,
        )
    except (ValueError, TypeError, msgpack.UnpackException) as exc:
        # ValueError covers truncation, extra data, bad UTF-8, limits and bad map keys.
        raise ProtoError(f"payload is not valid msgpack within the limits: {_text(exc)}") from None


def _unpacker(payload: bytes, limit: int) -> msgpack.Unpacker:
    return msgpack.Unpacker(io.BytesIO(payload), read_size=4096, raw=False,
                            strict_map_key=True, use_list=True,
                            max_bin_len=min(limit, MAX_IMAGE_BYTES), max_str_len=MAX_STR_LEN,
                            max_array_len=MAX_LIST_LEN, max_map_len=MAX_MAP_LEN, max_ext_len=0)


def _unpack_image(payload: bytes | bytearray | memoryview, limit: int) -> Any:
    """A raw image message as the encoder lays it out, unpacked with its pixels a view of
    ``payload`` (not copied: each subscriber of a frame would copy 691 KB at 640 x 360);
    None for anything else (JPEG, another layout, malformed), which :func:`_unpack` takes."""
    if not isinstance(payload, bytes):
        return None
    try:
        unpacker = _unpacker(payload, limit)
        if unpacker.read_map_header() != 2 or unpacker.unpack() != "header":
            return None
        header = unpacker.unpack()
        if unpacker.unpack() != "body":
            return None
        body: dict[str, Any] = {}
        entries = unpacker.read_map_header()
        for i in range(entries):
            key = unpacker.unpack()
            if key != "image":
                body[key] = unpacker.unpack()
                continue
            image = _image_map(unpacker, payload) if i == entries - 1 else None
            if image is None:
                return None
            body[key] = image
            return {"header": header, "body": body}
    except (ValueError, TypeError, IndexError, msgpack.UnpackException):
        return None
    return None


def _image_map(unpacker: msgpack.Unpacker, payload: bytes) -> dict[str, Any] | None:
    """The image's array map, ``data`` a read-only view of the payload's tail, or None when
    ``data`` is not its last entry, or its bytes not the payload's last."""
    if not 0x80 <= payload[unpacker.tell()] <= 0x8F:  # a small map: the array's
        return None
    image: dict[str, Any] = {}
    entries = unpacker.read_map_header()
    for i in range(entries):
        key = unpacker.unpack()
        if key == "data":
            if i != entries - 1:
                return None
            start, size = _bin_at(payload, unpacker.tell())
            if start + size != len(payload):
                return None
            image[key] = memoryview(payload)[start:]
            return image
        image[key] = unpacker.unpack()
    return None


def _bin_at(payload: bytes, at: int) -> tuple[int, int]:
    """Where the bin at ``at`` starts and its length (-1, -1: not a bin)."""
    widths = {0xC4: 1, 0xC5: 2, 0xC6: 4}
    width = widths.get(payload[at])
    if width is None:
        return -1, -1
    return at + 1 + width, int.from_bytes(payload[at + 1:at + 1 + width], "big")


def _text(exc: Exception) -> str:
    """An exception's message; some msgpack 1.0 releases leave it unformatted ('%s exceeds ...')."""
    template, *values = exc.args or ("",)
    if values and isinstance(template, str) and "%" in template:
        try:
            return template % tuple(values)
        except (TypeError, ValueError):  # a literal '%' in the data, not a template
            pass
    return str(exc)


def decode(payload: bytes | bytearray | memoryview, expected_kind: str | None = None) -> Message:
    """Decode and validate a payload.

    Parameters
    ----------
    payload : bytes-like
        The msgpack payload, e.g. ``sample.payload.to_bytes()``.
    expected_kind : str, optional
        Reject any other kind (and apply its size limit before unpacking).

    Returns
    -------
    Message
        The message, of the class ``MESSAGE_TYPES[kind]``.

    Raises
    ------
    ProtoError
        With a reason naming what does not fit; never any other exception.
    """
    if expected_kind is not None and expected_kind not in MESSAGE_TYPES:
        raise ProtoError(f"expected kind {expected_kind!r} is not one of {list(MESSAGE_TYPES)}")
    if not isinstance(payload, bytes | bytearray | memoryview):
        raise ProtoError(f"payload must be bytes, got {type_name(payload)}")
    size = memoryview(payload).nbytes
    limit = payload_limit(expected_kind)
    if size == 0:
        raise ProtoError("payload is empty")
    if size > limit:
        raise ProtoError(f"payload of {size} bytes exceeds the limit of {limit}")
    obj = _unpack_image(payload, limit) if expected_kind in IMAGE_KINDS else None
    if obj is None:
        obj = _unpack(payload, limit)
    if not isinstance(obj, dict):
        raise ProtoError(f"message: expected a map, got {type_name(obj)}")
    if "header" not in obj:
        raise ProtoError("message: missing field 'header'")
    kind = read_kind(obj["header"])
    check_keys(obj, TOP_KEYS, "message")
    cls = MESSAGE_TYPES.get(kind)
    if cls is None:
        raise ProtoError(f"header.kind: {kind[:40]!r} is not one of {list(MESSAGE_TYPES)}")
    if expected_kind is not None and kind != expected_kind:
        raise ProtoError(f"header.kind: expected {expected_kind!r}, got {kind!r}")
    if size > payload_limit(kind):
        raise ProtoError(
            f"{kind}: payload of {size} bytes exceeds the limit of {payload_limit(kind)}"
        )
    return cls.from_dict(obj["body"], Header.from_dict(obj["header"]))
