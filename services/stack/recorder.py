"""Recording files: every result message of a stream, to load later.

A recording is the 18 bytes ``AAMTRACK-RECORD-1\\n`` followed by records, each
a 4-byte little-endian unsigned length and that many bytes of one message
payload exactly as published (the msgpack encoding of ``proto/README.md``).
Any program that reads the message contract can read a recording::

    from services.stack.recorder import load_messages
    fits = [m for m in load_messages("run.rec") if m.KIND == "fit"]

The writer flushes at least once a second, so a recording whose writer died
(a killed launcher, a lost machine) keeps all but its last second; a reader
returns every complete record before a damaged one and says where it stopped
(:func:`read_recording`).
"""

from __future__ import annotations

import logging
import struct
import threading
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

from proto import Message, ProtoError, decode
from proto.codec import payload_limit
from proto.keys import IMAGES, RESULTS

MAGIC = b"AAMTRACK-RECORD-1\n"
RESULT_KINDS = (*RESULTS, "status", "eos")
"""Kinds recorded by default; frames and overlays only when asked."""
IMAGE_KINDS = IMAGES
_LENGTH = struct.Struct("<I")
FLUSH_PERIOD = 1.0
"""Seconds at most between a write and its flush to the file."""

log = logging.getLogger("aamtrack.recorder")


class RecordingError(ValueError):
    """A file is not a recording or is damaged; the message says where."""


class RecordWriter:
    """Append message payloads to a recording file (thread-safe).

    Parameters
    ----------
    path : path
        The file; created or truncated.

    Raises
    ------
    OSError
        When the file cannot be created or its first bytes written.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.count = 0
        self.late = 0
        """Messages that came after :meth:`close`, or after the file failed, left out."""
        self.error = ""
        """Why the file could no longer be written (a full disk), once it could not; every
        complete record before stays readable (:func:`read_recording`)."""
        self._lock = threading.Lock()
        self._file: BinaryIO | None = open(self.path, "wb")  # noqa: SIM115 (closed in close())
        self._file.write(MAGIC)
        self._file.flush()
        self._flushed = time.monotonic()

    def write(self, payload: bytes) -> None:
        """Append one encoded message (flushed within :data:`FLUSH_PERIOD`); after
        :meth:`close` (messages still arriving while the run stops) or a failed write it
        is left out."""
        with self._lock:
            if self._file is None:
                self.late += 1
                return
            try:
                self._file.write(_LENGTH.pack(len(payload)) + payload)
                self.count += 1
                if time.monotonic() - self._flushed >= FLUSH_PERIOD:
                    self._flush()
            except OSError as exc:
                self._fail(exc)

    def flush(self) -> None:
        """Write everything so far to the file."""
        with self._lock:
            if self._file is not None:
                try:
                    self._flush()
                except OSError as exc:
                    self._fail(exc)

    def _flush(self) -> None:
        assert self._file is not None
        self._file.flush()
        self._flushed = time.monotonic()

    def _fail(self, exc: OSError) -> None:
        """Stop writing after a failed write; what reached the file stays."""
        self.error = f"{self.path}: cannot be written ({exc.strerror or exc})"
        log.debug("%s", self.error)
        file, self._file = self._file, None
        try:
            if file is not None:
                file.close()
        except OSError:
            pass  # the buffer that could not be written is lost with the device's space

    def close(self) -> None:
        """Flush and close the file. Idempotent."""
        with self._lock:
            if self._file is not None:
                try:
                    self._file.close()
                except OSError as exc:
                    self._fail(exc)
                self._file = None

    def __enter__(self) -> RecordWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@dataclass
class Recording:
    """What a recording file holds.

    Attributes
    ----------
    messages : list of Message
    stopped : str
        Empty when every record was read; else where and why reading stopped
        (a record cut short by a writer that died, or damaged).
    """

    messages: list[Message]
    stopped: str = ""


def _records(f: BinaryIO, path: Path) -> Iterator[tuple[int, int, bytes]]:
    """``(index, offset, payload)`` of each complete record after the magic; raises at the
    first bad one."""
    index, offset = 0, len(MAGIC)
    while head := f.read(_LENGTH.size):
        where = f"{path}: record {index} at byte {offset}"
        if len(head) < _LENGTH.size:
            raise RecordingError(f"{where}: truncated in its length")
        (size,) = _LENGTH.unpack(head)
        if size > payload_limit(None):
            raise RecordingError(f"{where}: claims {size} bytes, over the largest message "
                                 f"of {payload_limit(None)}")
        payload = f.read(size)
        if len(payload) < size:
            raise RecordingError(f"{where}: truncated ({len(payload)} of {size} bytes)")
        yield index, offset, payload
        index, offset = index + 1, offset + _LENGTH.size + size


def read_recording(path: str | Path, kinds: Iterable[str] | None = None) -> Recording:
    """Every complete, valid message of a recording (optionally only some kinds).

    Reading stops at the first record that is cut short, oversized or does
    not decode; what came before it is returned and :attr:`Recording.stopped`
    says where.

    Raises
    ------
    RecordingError
        When the file is not a recording at all.
    OSError
        When it cannot be read.
    """
    path = Path(path)
    wanted = None if kinds is None else set(kinds)
    messages: list[Message] = []
    with open(path, "rb") as f:
        if f.read(len(MAGIC)) != MAGIC:
            raise RecordingError(f"{path}: not an aamtrack recording (bad magic)")
        try:
            for index, offset, payload in _records(f, path):
                try:
                    msg = decode(payload)
                except ProtoError as exc:
                    raise RecordingError(f"{path}: record {index} at byte {offset} does not "
                                         f"decode: {exc.reason}") from None
                if wanted is None or msg.KIND in wanted:
                    messages.append(msg)
        except RecordingError as exc:
            return Recording(messages, str(exc))
    return Recording(messages)


def load_messages(path: str | Path, kinds: Iterable[str] | None = None) -> list[Message]:
    """The messages of :func:`read_recording`, warning when reading stopped early."""
    recording = read_recording(path, kinds)
    if recording.stopped:
        log.warning("read %d messages, then stopped: %s", len(recording.messages),
                    recording.stopped)
    return recording.messages
