"""What a process of a run trusts: its keys, the keys files, and one answer per index.

A launcher gives each service process its keys (:class:`proto.auth.Keyring`: its own
private key and the run's public keys) over a channel only that process holds
(:mod:`services.bus.handover`), never in its environment or on its command line; every
process holding a private key is non-dumpable (:func:`harden`) and untraced before it gets
it, so that another process of the same user can read neither its memory nor its open
files (root, and a process allowed to trace it, still can). A service started on its own
reads a keys file (:func:`read_keys_file`: of its user, closed to others), as a deployment
over several hosts gives each host.

:class:`Replays` keeps, per producer, kind and run, the indices already accepted: a signed
message sent again (a replayed frame, fit, status or end of stream) is ignored and counted.
A restarted service also gets its run's high-water marks (:data:`Floors`): what its
predecessor could have had is refused, so that a replay cannot answer a frame late.
"""

from __future__ import annotations

import collections
import ctypes
import os
import stat
import threading
from pathlib import Path

from proto import Message
from proto.auth import Keyring

MAX_AGE_S = 60.0
"""A signed message published longer ago than this (or as far ahead, by the receiver's
clock) is stale: the window in which a message of an ended run could be sent again."""
REPLAY_WINDOW = 4096
"""Indices remembered per producer, kind and run; an index older than all of them is
refused as stale (a run's indices only grow)."""
MAX_STREAMS = 64
"""Producer, kind and run triples followed at once (the oldest is forgotten)."""
IGNORED = ("another run", "not its key's owner", "not a service of the run", "unsigned",
           "bad signature", "replayed", "before the restart", "stale")
"""Why a well-formed message is ignored, as counted."""
_PR_SET_DUMPABLE, _PR_GET_DUMPABLE = 4, 3

Floors = dict[tuple[str, str], int]
"""(producer, kind) -> the highest frame index of the run the launcher had seen when it
restarted a service: the new process refuses that index and every earlier one."""

_inherited: Keyring | None = None
_floors: Floors = {}


def harden() -> bool:
    """Make this process non-dumpable: processes of the same user (without the right to
    trace it) can no longer read its memory, environment or open files, nor attach to it.
    False where the call is not available."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_DUMPABLE, 0, 0, 0, 0) == 0 and not dumpable()
    except (OSError, AttributeError):
        return False


def dumpable() -> bool:
    """Whether this process is still dumpable (True where that cannot be known)."""
    try:
        return ctypes.CDLL(None).prctl(_PR_GET_DUMPABLE, 0, 0, 0, 0) != 0
    except (OSError, AttributeError):
        return True


def tracer_of(pid: int | str = "self") -> int:
    """The pid tracing process ``pid`` (0: none), from ``/proc/<pid>/status``; -1 where it
    cannot be read."""
    try:
        with open(f"/proc/{pid}/status") as status:
            for line in status:
                if line.startswith("TracerPid:"):
                    return int(line.split()[1])
    except (OSError, ValueError):
        pass
    return -1


def insecurity() -> str:
    """Why this process cannot keep a key from other processes of its user ("" when it
    can): it could not make itself non-dumpable, or it is traced."""
    if dumpable():
        return "it cannot make itself non-dumpable (no prctl)"
    tracer = tracer_of()
    if tracer:
        return ("it is traced by pid " + str(tracer) if tracer > 0
                else "its tracer cannot be read (/proc/self/status)")
    return ""


def keep(keyring: Keyring, floors: Floors | None = None) -> None:
    """Keep the keyring (and, in a restarted service, the run's high-water marks) this
    process was handed, for :func:`inherited` and :func:`inherited_floors`."""
    global _inherited, _floors
    _inherited, _floors = keyring, dict(floors or {})


def inherited() -> Keyring:
    """The keyring this process was given (empty: none; it then signs and checks nothing)."""
    return _inherited or Keyring()


def inherited_floors() -> Floors:
    """The run's high-water marks handed to this process at a restart (empty otherwise)."""
    return dict(_floors)


def _keys_file_problem(path: Path, info: os.stat_result) -> str:
    if not stat.S_ISREG(info.st_mode):
        return "not a regular file"
    if info.st_uid != os.geteuid():
        return f"owned by uid {info.st_uid}, not by this user (uid {os.geteuid()})"
    if info.st_mode & (stat.S_IRWXG | stat.S_IRWXO):
        return (f"mode {stat.S_IMODE(info.st_mode):o}: others may read or change it "
                "(chmod 600 it)")
    folder = path.absolute().parent.stat()
    if folder.st_mode & (stat.S_IWGRP | stat.S_IWOTH) and not folder.st_mode & stat.S_ISVTX:
        return f"its folder {path.absolute().parent} may be written by others"
    return ""


def read_keys_file(path: str | Path, signer: str = "") -> Keyring:
    """A keys file (``aamtrack keys``): a regular file of this user, mode 600 or closer, in
    a folder others cannot write; every key of the right length. With ``signer``, the
    keyring of that service (its private key, every public key); else the whole file's.

    Raises
    ------
    ValueError
        Naming the file and what is wrong with it.
    """
    path = Path(path)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW)
    except OSError as exc:
        why = "a symbolic link" if exc.errno == 40 else (exc.strerror or str(exc))
        raise ValueError(f"keys file {path}: {why}") from None
    with os.fdopen(fd, "rb") as f:
        problem = _keys_file_problem(path, os.fstat(f.fileno()))
        data = b"" if problem else f.read()
    if problem:
        raise ValueError(f"keys file {path}: {problem}")
    try:
        keyring = Keyring.from_bytes(data)
    except ValueError as exc:
        raise ValueError(f"keys file {path}: {exc}") from None
    if not signer:
        return keyring
    return keyring.for_service(signer) if signer in keyring.secrets else keyring.public_only()


def write_keys_file(path: str | Path, keyring: Keyring) -> None:
    """Write ``keyring`` to a new file of mode 0600 (never over an existing one)."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600)
    with os.fdopen(fd, "wb") as f:
        f.write(keyring.to_bytes())


class _Window:
    """The indices of one producer's stream accepted so far, the last :data:`REPLAY_WINDOW`."""

    def __init__(self, size: int) -> None:
        self.size = size
        self.seen: set[object] = set()
        self.order: collections.deque[object] = collections.deque()
        self.floor: int | None = None

    def first(self, index: object, rank: int) -> bool:
        if index in self.seen or (self.floor is not None and rank <= self.floor):
            return False
        self.seen.add(index)
        self.order.append((index, rank))
        if len(self.order) > self.size:
            old, old_rank = self.order.popleft()
            self.seen.discard(old)
            self.floor = old_rank if self.floor is None else max(self.floor, old_rank)
        return True


def index_of(message: Message) -> tuple[object, int]:
    """What may be answered once in ``message``'s stream, and its rank (growing in a run):
    a frame's or overlay's index, a result's frame and face, the end of stream, the
    publication time of a status or of a detector's boxes."""
    h = message.header
    kind = message.KIND
    if kind in ("fit", "pose", "expression"):
        return (h.frame_index, message.face_id), h.frame_index  # type: ignore[attr-defined]
    if kind in ("frame", "overlay"):
        return h.frame_index, h.frame_index
    if kind == "eos":
        return "eos", 0
    return h.publish_time_ns, h.publish_time_ns


FLOORED = ("frame", "fit", "pose", "expression", "overlay")
"""Kinds whose frame index a restarted service's floors apply to."""


class Replays:
    """Which indices each producer's stream has had: one index is accepted once.

    Keyed by producer, kind and run (and the restart count of a status's process), at
    most :data:`MAX_STREAMS` streams of :data:`REPLAY_WINDOW` indices each.
    """

    def __init__(self, window: int = REPLAY_WINDOW) -> None:
        self.window = window
        self._streams: collections.OrderedDict[tuple, _Window] = collections.OrderedDict()
        self._lock = threading.Lock()

    def first(self, message: Message) -> bool:
        """Whether ``message``'s index is new in its stream (it is then remembered)."""
        h = message.header
        stream: tuple = (h.producer, message.KIND, h.run_id)
        if message.KIND == "status":
            stream += (message.restarts,)  # type: ignore[attr-defined]
        index, rank = index_of(message)
        with self._lock:
            window = self._streams.get(stream)
            if window is None:
                window = self._streams[stream] = _Window(self.window)
                if len(self._streams) > MAX_STREAMS:
                    self._streams.popitem(last=False)
            return window.first(index, rank)


def below_floor(message: Message, floors: Floors) -> bool:
    """Whether ``message`` is of a frame its run had reached when this process was
    restarted (:data:`Floors`)."""
    if message.KIND not in FLOORED:
        return False
    floor = floors.get((message.header.producer, message.KIND))
    return floor is not None and message.header.frame_index <= floor
