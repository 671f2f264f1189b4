"""What a process of a run trusts: its keys, how it gets them, and one answer per index.

A launcher gives each service process its keys (:class:`proto.auth.Keyring`) through a
pipe the process inherits (:func:`read_key_pipe`), never in its environment or on its
command line, where any process of the same user could read them
(``/proc/<pid>/environ``, ``ps``); the process first makes itself non-dumpable
(:func:`harden`), so that such a process cannot read its memory or its open pipe either
(root, and a user allowed to trace it, still can). A service started on its own reads a
keys file (:func:`read_keys_file`: of its user, closed to others), as a deployment over
several hosts gives each host.

:class:`Replays` keeps, per producer, kind and run, the indices already accepted: a signed
message sent again (a replayed frame, fit, status or end of stream) is ignored and counted.
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
           "bad signature", "replayed", "stale")
"""Why a well-formed message is ignored, as counted."""
_PR_SET_DUMPABLE = 4

_inherited: Keyring | None = None


def harden() -> bool:
    """Make this process non-dumpable: processes of the same user (without the right to
    trace it) can no longer read its memory, environment or open files. False where the
    call is not available."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_DUMPABLE, 0, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def read_key_pipe(fd: int) -> Keyring:
    """Read this process's keyring from the inherited pipe ``fd`` (closed after) and keep
    it for :func:`inherited`.

    Raises
    ------
    ValueError
        When what the pipe holds is not a keyring.
    """
    global _inherited
    with os.fdopen(fd, "rb") as pipe:
        _inherited = Keyring.from_bytes(pipe.read())
    return _inherited


def inherited() -> Keyring:
    """The keyring this process was given (empty: none; it then signs and checks nothing)."""
    return _inherited or Keyring()


def read_keys_file(path: str | Path, signer: str = "") -> Keyring:
    """A keys file (``aamtrack keys``), which must be this user's and closed to others.

    Raises
    ------
    ValueError
        Naming the file and what is wrong with it.
    """
    path = Path(path)
    try:
        info = path.stat()
        data = path.read_bytes()
    except OSError as exc:
        raise ValueError(f"keys file {path}: {exc.strerror or exc}") from None
    if info.st_uid != os.geteuid():
        raise ValueError(f"keys file {path}: owned by another user")
    if info.st_mode & (stat.S_IRWXG | stat.S_IRWXO):
        raise ValueError(f"keys file {path}: others may read it (chmod 600 it)")
    try:
        keyring = Keyring.from_bytes(data)
    except ValueError as exc:
        raise ValueError(f"keys file {path}: {exc}") from None
    return Keyring(keyring.keys, signer if signer in keyring.keys else "")


def write_keys_file(path: str | Path, keyring: Keyring) -> None:
    """Write ``keyring`` to a new file of mode 0600 (never over an existing one)."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
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
