"""The header every message carries, and the schema version.

On the wire the header is a map whose first two entries are
``schema_version`` and ``kind``; a receiver reads those two first and rejects
a version other than :data:`SCHEMA_VERSION` before it looks at anything else.
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass, fields
from typing import Any

from proto.fields import Int, Str, check_keys, is_int, type_name
from proto.keys import check_name
from proto.limits import ProtoError

SCHEMA_VERSION = 8
"""Version of the message contract; any change to a field or a rule bumps it.
Version 2: ``run_id`` in the header; ``fit.similarity`` (was ``pose``) and the
fit's frame size; ``status.lost`` and ``status.ignored``. Version 3:
``media_time_ns`` in the header. Version 4: ``status.failed``, the header's ``auth``, the
fit's appearance as one map (nil without one), ``warp_path`` ``none``. Version 5: every face
in the frame: ``face_id`` in ``fit``, ``pose`` and ``expression``, ``fit.faces``. Version 6:
``auth`` signs every message of a run, with its producer's key, over the whole message
(:mod:`proto.auth`). Version 7: ``auth`` is an Ed25519 signature (128 hex digits) of the
message's digest, which any reader checks with the producer's public key."""


AUTH_HEX = 128
"""Hex digits of a signature: an Ed25519 signature of 64 bytes (:mod:`proto.auth`)."""
_HEX = re.compile(f"[0-9a-f]{{{AUTH_HEX}}}")


def check_auth(value: str, name: str = "header.auth") -> str:
    """A signature is empty or :data:`AUTH_HEX` lower-case hex digits."""
    if value and _HEX.fullmatch(value) is None:
        raise ProtoError(f"{name}: expected empty or {AUTH_HEX} lower-case hex digits")
    return value


def check_run_id(value: str, what: str = "run id") -> str:
    """A run id is empty (no run) or a name (:func:`proto.keys.check_name`)."""
    return value if value == "" else check_name(value, what)


_SPECS = {
    "stream_id": Str(validate=check_name),
    "frame_index": Int(),
    "capture_time_ns": Int(),
    "producer": Str(validate=check_name),
    "publish_time_ns": Int(),
    "run_id": Str(validate=check_run_id),
    "media_time_ns": Int(),
    "auth": Str(max_len=AUTH_HEX, validate=check_auth),
}
WIRE_KEYS = ("schema_version", "kind", *_SPECS)
"""Keys of the wire header, in their order."""


@dataclass(frozen=True)
class Header:
    """Where a message comes from and which frame it is about.

    Parameters
    ----------
    stream_id : str
        The video stream; a key chunk (see :func:`proto.keys.check_name`).
    frame_index : int
        Index of the frame from 0 (for ``Status``: the last frame the producer
        handled, 0 before the first; for ``EndOfStream``: the last frame index).
    capture_time_ns : int
        Capture time of the frame, nanoseconds since the Unix epoch (UTC).
    producer : str
        Name of the service that published the message; a key chunk.
    publish_time_ns : int
        Publication time, nanoseconds since the Unix epoch (UTC).
    run_id : str
        The run of the source the frame comes from (a name, or empty outside
        any run): a source starts a new run each time it starts, so that a
        frame's index and size are read within its run, and messages of other
        runs can be told apart and ignored.
    media_time_ns : int
        Time of the frame on its video's own clock, nanoseconds from the run's
        first frame: a file's frame position (its index over its frame rate),
        whatever the pace of the run; for a camera or a stream, its capture
        time less the first frame's. Smoothing over time and exported
        timestamps read it, so that a file gives the same results run fast or
        in real time.
    auth : str
        The producer's signature of the whole message (:mod:`proto.auth`), so that no
        program without the producer's key can forge or alter a message of the run;
        empty outside a run that has keys.
    """

    stream_id: str
    frame_index: int
    capture_time_ns: int
    producer: str
    publish_time_ns: int
    run_id: str = ""
    media_time_ns: int = 0
    auth: str = ""

    def __post_init__(self) -> None:
        for f in fields(self):
            value = _SPECS[f.name].check(getattr(self, f.name), f"header.{f.name}")
            object.__setattr__(self, f.name, value)

    @classmethod
    def now(
        cls,
        stream_id: str,
        frame_index: int,
        producer: str,
        capture_time_ns: int | None = None,
        run_id: str = "",
        media_time_ns: int = 0,
    ) -> Header:
        """A header published now; the capture time defaults to now as well."""
        published = time.time_ns()
        captured = published if capture_time_ns is None else capture_time_ns
        return cls(stream_id, frame_index, captured, producer, published, run_id, media_time_ns)

    def to_dict(self, kind: str) -> dict[str, Any]:
        """The wire map of this header for a message of ``kind``."""
        return {"schema_version": SCHEMA_VERSION, "kind": kind} | {
            name: getattr(self, name) for name in _SPECS
        }

    @classmethod
    def from_dict(cls, obj: dict[str, Any]) -> Header:
        """Build a header from a wire map already passed through :func:`read_kind`."""
        check_keys(obj, WIRE_KEYS, "header")
        return cls(**{name: obj[name] for name in _SPECS})


def read_kind(obj: Any) -> str:
    """Check a wire header's schema version and return its kind (not yet validated).

    Raises
    ------
    ProtoError
        If ``obj`` is not a map, or its ``schema_version`` is missing, not an
        integer or not :data:`SCHEMA_VERSION`, or its ``kind`` is not a string.
    """
    if not isinstance(obj, dict):
        raise ProtoError(f"header: expected a map, got {type_name(obj)}")
    for key in ("schema_version", "kind"):
        if key not in obj:
            raise ProtoError(f"header: missing field {key!r}")
    version = obj["schema_version"]
    if not is_int(version):
        raise ProtoError(f"header.schema_version: expected an integer, got {type_name(version)}")
    if version != SCHEMA_VERSION:
        age = "older" if version < SCHEMA_VERSION else "newer"
        raise ProtoError(
            f"header.schema_version: message has schema version {version} ({age}), "
            f"this decoder reads only version {SCHEMA_VERSION}"
        )
    kind = obj["kind"]
    if not isinstance(kind, str):
        raise ProtoError(f"header.kind: expected a string, got {type_name(kind)}")
    return kind
