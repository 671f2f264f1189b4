"""Recording files: every result message of a stream, to load later.

A recording is the 18 bytes ``AAMTRACK-RECORD-1\\n`` followed by records, each
a 4-byte little-endian unsigned length and that many bytes of one message
payload exactly as published (the msgpack encoding of ``proto/README.md``).
Any program that reads the message contract can read a recording::

    from services.stack.recorder import load_messages
    fits = [m for m in load_messages("run.rec") if m.KIND == "fit"]
"""

from __future__ import annotations

import struct
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import BinaryIO

from proto import Message, ProtoError, decode
from proto.codec import payload_limit

MAGIC = b"AAMTRACK-RECORD-1\n"
RESULT_KINDS = ("boxes", "fit", "pose", "expression", "status", "eos")
"""Kinds recorded by default; frames and overlays only when asked."""
IMAGE_KINDS = ("frame", "overlay")
_LENGTH = struct.Struct("<I")


class RecordingError(ValueError):
    """A file is not a recording or is damaged; the message says where."""


class RecordWriter:
    """Append message payloads to a recording file (thread-safe).

    Parameters
    ----------
    path : path
        The file; created or truncated.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.count = 0
        self._lock = threading.Lock()
        self._file: BinaryIO | None = open(self.path, "wb")  # noqa: SIM115 (closed in close())
        self._file.write(MAGIC)

    def write(self, payload: bytes) -> None:
        """Append one encoded message."""
        with self._lock:
            if self._file is None:
                raise ValueError(f"recording {self.path} is closed")
            self._file.write(_LENGTH.pack(len(payload)))
            self._file.write(payload)
            self.count += 1

    def close(self) -> None:
        """Flush and close the file. Idempotent."""
        with self._lock:
            if self._file is not None:
                self._file.close()
                self._file = None

    def __enter__(self) -> RecordWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def read_payloads(path: str | Path) -> Iterator[bytes]:
    """The payloads of a recording, in order.

    Raises
    ------
    RecordingError
        If the file does not start with the recording magic, a record is
        longer than any message may be, or the file ends inside a record.
    """
    path = Path(path)
    with open(path, "rb") as f:
        if f.read(len(MAGIC)) != MAGIC:
            raise RecordingError(f"{path}: not an aamtrack recording (bad magic)")
        index = 0
        while head := f.read(_LENGTH.size):
            if len(head) < _LENGTH.size:
                raise RecordingError(f"{path}: truncated in the length of record {index}")
            (size,) = _LENGTH.unpack(head)
            if size > payload_limit(None):
                raise RecordingError(f"{path}: record {index} claims {size} bytes, over the "
                                     f"largest message of {payload_limit(None)}")
            payload = f.read(size)
            if len(payload) < size:
                raise RecordingError(f"{path}: truncated inside record {index}")
            yield payload
            index += 1


def load_messages(path: str | Path, kinds: Iterable[str] | None = None) -> list[Message]:
    """Decode every message of a recording (optionally only some kinds).

    Raises
    ------
    RecordingError
        For a damaged file or a record that does not decode (naming it).
    """
    wanted = None if kinds is None else set(kinds)
    messages = []
    for index, payload in enumerate(read_payloads(path)):
        try:
            msg = decode(payload)
        except ProtoError as exc:
            raise RecordingError(f"{path}: record {index} does not decode: {exc.reason}") from None
        if wanted is None or msg.KIND in wanted:
            messages.append(msg)
    return messages
