"""Recording files: every result message of a stream, checked against the run's keys when
read.

A recording is the 18 bytes ``AAMTRACK-RECORD-2\\n`` followed by records, each a 4-byte
little-endian unsigned length and that many bytes. The first record is the run's public
keys as its launcher signed them (:func:`proto.auth.keys_document`; empty in a recording of
a run without keys); every other is one message payload exactly as published (the msgpack
encoding of ``proto/README.md``). Any program that reads the message contract can read a
recording::

    from services.stack.recorder import load_messages
    fits = [m for m in load_messages("run.rec") if m.KIND == "fit"]

A reader keeps only the messages signed by the run's services (:func:`read_recording`):
a recording holds what a reader of the bus received, forged messages included, and each is
checked again when read. The launcher key it trusts is given with ``trust`` (its
fingerprint); without it, the key the recording names, as :attr:`Recording.run_keys` says.
A recording of format 1 (``AAMTRACK-RECORD-1``, no keys) is read unverified.

The writer flushes at least once a second, so a recording whose writer died
(a killed launcher, a lost machine) keeps all but its last second; a reader
returns every complete record before a damaged one and says where it stopped.
"""

from __future__ import annotations

import logging
import struct
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

from proto import Message, ProtoError, decode
from proto.auth import RunKeys, read_keys_document
from proto.codec import payload_limit
from proto.keys import IMAGES, OWNERS, RESULTS

MAGIC = b"AAMTRACK-RECORD-2\n"
MAGIC_UNVERIFIED = b"AAMTRACK-RECORD-1\n"
"""Recordings made before they held the run's keys: read, but nothing is verified."""
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
    keys : bytes
        The run's keys document (:func:`proto.auth.keys_document`; empty: a run without
        keys), its first record.
    clock : callable
        Seconds on a monotonic clock, which :data:`FLUSH_PERIOD` is counted on.

    Raises
    ------
    OSError
        When the file cannot be created or its first bytes written.
    """

    def __init__(self, path: str | Path, keys: bytes = b"",
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.path = Path(path)
        self._clock = clock
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.count = 0
        self.late = 0
        """Messages that came after :meth:`close`, or after the file failed, left out."""
        self.error = ""
        """Why the file could no longer be written (a full disk), once it could not; every
        complete record before stays readable (:func:`read_recording`)."""
        self._lock = threading.Lock()
        self._file: BinaryIO | None = open(self.path, "wb")  # noqa: SIM115 (closed in close())
        self._file.write(MAGIC + _LENGTH.pack(len(keys)) + keys)
        self._file.flush()
        self._flushed = self._clock()

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
                if self._clock() - self._flushed >= FLUSH_PERIOD:
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
        self._flushed = self._clock()

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
        The messages kept: those signed by the run's services, when it has keys.
    stopped : str
        Empty when every record was read; else where and why reading stopped
        (a record cut short by a writer that died, or damaged).
    run_keys : RunKeys, optional
        The run's keys every message kept was checked against (None: unverified).
    ignored : dict of str to int
        Messages left out, by why (:data:`services.bus.trust.IGNORED`).
    """

    messages: list[Message]
    stopped: str = ""
    run_keys: RunKeys | None = None
    ignored: dict[str, int] = field(default_factory=dict)

    @property
    def verified(self) -> str:
        """What the messages were checked against, in words."""
        if self.run_keys is None:
            return "unverified (a recording without its run's keys)"
        return (f"verified: run {self.run_keys.run_id or '?'}, launcher key "
                f"{self.run_keys.fingerprint}")


def _records(f: BinaryIO, path: Path, offset: int) -> Iterator[tuple[int, int, bytes]]:
    """``(index, offset, payload)`` of each complete record from ``offset``; raises at the
    first bad one."""
    index = 0
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


def _run_keys(f: BinaryIO, path: Path, trust: str) -> tuple[RunKeys | None, int]:
    """The run's keys of a recording (after its magic) and where its messages start."""
    head = f.read(_LENGTH.size)
    (size,) = _LENGTH.unpack(head) if len(head) == _LENGTH.size else (-1,)
    data = f.read(size) if 0 <= size <= payload_limit(None) else b""
    if size < 0 or len(data) != size:
        raise RecordingError(f"{path}: its run's keys are cut short")
    if not data:
        return None, len(MAGIC) + _LENGTH.size
    try:
        return read_keys_document(data, trust), len(MAGIC) + _LENGTH.size + size
    except ValueError as exc:
        raise RecordingError(f"{path}: {exc}") from None


def read_recording(path: str | Path, kinds: Iterable[str] | None = None, trust: str = ""
                   ) -> Recording:
    """Every complete, valid message of a recording (optionally only some kinds) signed by
    its run's services (:class:`RecordingCheck`).

    Reading stops at the first record that is cut short, oversized or does
    not decode; what came before it is returned and :attr:`Recording.stopped`
    says where.

    Raises
    ------
    RecordingError
        When the file is not a recording at all, its keys are not its launcher's, or its
        launcher is not the one ``trust`` names.
    OSError
        When it cannot be read.
    """
    path = Path(path)
    wanted = None if kinds is None else set(kinds)
    messages: list[Message] = []
    with open(path, "rb") as f:
        magic = f.read(len(MAGIC))
        if magic not in (MAGIC, MAGIC_UNVERIFIED):
            raise RecordingError(f"{path}: not an aamtrack recording (bad magic)")
        run_keys, start = _run_keys(f, path, trust) if magic == MAGIC else (None, len(MAGIC))
        if run_keys is None and trust:
            raise RecordingError(f"{path}: holds no run's keys to check against --trust")
        check = RecordingCheck(run_keys)
        try:
            for index, offset, payload in _records(f, path, start):
                try:
                    msg = decode(payload)
                except ProtoError as exc:
                    raise RecordingError(f"{path}: record {index} at byte {offset} does not "
                                         f"decode: {exc.reason}") from None
                if (wanted is None or msg.KIND in wanted) and check.keeps(payload, msg):
                    messages.append(msg)
        except RecordingError as exc:
            return Recording(messages, str(exc), run_keys, check.ignored)
    return Recording(messages, "", run_keys, check.ignored)


class RecordingCheck:
    """Which recorded messages are the run's: signed by the service that owns their kind (a
    status by its service), of the run, each index once; None keys: every one."""

    def __init__(self, run_keys: RunKeys | None) -> None:
        from services.bus.trust import Replays

        self.run_keys = run_keys
        self.replays = Replays()
        self.ignored: dict[str, int] = {}

    def _why(self, payload: bytes, msg: Message) -> str:
        assert self.run_keys is not None
        h = msg.header
        owner = msg.service if msg.KIND == "status" else OWNERS.get(msg.KIND)  # type: ignore
        if h.producer != owner:
            return "not its key's owner"
        if self.run_keys.run_id and h.run_id != self.run_keys.run_id and h.run_id:
            return "another run"
        problem = self.run_keys.keyring.problem(payload, msg)
        if problem:
            return problem
        return "" if self.replays.first(msg) else "replayed"

    def keeps(self, payload: bytes, msg: Message) -> bool:
        if self.run_keys is None:
            return True
        why = self._why(payload, msg)
        if why:
            self.ignored[why] = self.ignored.get(why, 0) + 1
        return not why


def load_messages(path: str | Path, kinds: Iterable[str] | None = None) -> list[Message]:
    """The messages of :func:`read_recording`, warning when reading stopped early."""
    recording = read_recording(path, kinds)
    if recording.ignored:
        log.warning("left out %s messages not signed by the run's services",
                    sum(recording.ignored.values()))
    if recording.stopped:
        log.warning("read %d messages, then stopped: %s", len(recording.messages),
                    recording.stopped)
    return recording.messages
