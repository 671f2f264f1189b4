"""Where received messages wait: screened on arrival, so that nothing invalid takes a slot.

Every sample is screened in the Zenoh callback, before it is kept
(:meth:`Screen.check`): its size and encoding (:func:`proto.decode`), its
kind, its stream, its producer (only the service that owns a key may publish
on it), its run and, in a run with keys, its producer's signature, its age and
whether its index came before (:mod:`services.bus.trust`). An invalid sample is
counted as rejected, a valid one that is not the run's, not vouched for or sent
again as ignored (by reason); none of them can push a real frame out.

Three holders keep what passes (only an :class:`Inbox`, a service's main
input, counts what it gives in ``frames_in``):

- :class:`Inbox`: the latest ``capacity`` messages, taken in order (a full
  inbox drops its oldest, counted as dropped);
- :class:`Latest`: only the last message (e.g. the frame a detector searches);
- :class:`Recent`: the last few messages by frame index (e.g. the frame a
  pose belongs to); one pushed out is not counted (a message looked up that is
  gone is counted by its consumer, as dropped work).
"""

from __future__ import annotations

import collections
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from proto import Message, ProtoError, decode
from proto.auth import Keyring
from proto.keys import owner_of
from services.bus.stats import FrameNumbering, ServiceStats
from services.bus.trust import FLOORED, MAX_AGE_S, Floors, Replays, below_floor


@dataclass(frozen=True)
class Received:
    """A message that passed the screen.

    Attributes
    ----------
    message : Message
    payload : bytes
        Its encoded bytes (e.g. to forward a frame without encoding it again).
    key : str
        The key it arrived on.
    received_ns : int
        ``time.time_ns()`` when Zenoh delivered it.
    """

    message: Message
    payload: bytes
    key: str
    received_ns: int


class Screen:
    """Decides for each sample: keep, reject (invalid) or ignore (valid, not vouched for).

    Parameters
    ----------
    stream : str
        The service's stream id.
    run_id : str
        Accept only this run; empty: any run.
    stats : ServiceStats
    reject : callable
        ``reject(source, reason)``: counts and logs a rejected sample.
    keyring : Keyring, optional
        The keys of the run's producers (:mod:`proto.auth`): every message must carry
        its producer's signature, be fresh (:data:`.trust.MAX_AGE_S`) and, where the
        caller keeps :class:`.trust.Replays`, be the first of its index. None or empty:
        nothing is checked (a process outside any keyed run).
    restarted : bool
        The service's process is a restart: frames are numbered from the first it sees.
    floors : Floors, optional
        A restarted process's high-water marks of its run (:mod:`.trust`): a message of a
        frame at or below its producer's is ignored (``before the restart``), and so is one
        published before the process subscribed (:attr:`since_ns`): a frame sent while no
        process of the service listened was lost, and stays so.
    """

    def __init__(
        self, stream: str, run_id: str, stats: ServiceStats, reject: Callable[[str, str], None],
        keyring: Keyring | None = None, restarted: bool = False, floors: Floors | None = None,
    ) -> None:
        self.stream = stream
        self.run_id = run_id
        self.stats = stats
        self.reject = reject
        self.keyring = keyring or Keyring()
        self.restarted = restarted
        self.floors = dict(floors or {})
        self.since_ns = 0
        """In a restarted process, when it first subscribed (:meth:`subscribing`)."""

    def check(self, payload: bytes, key: str, kind: str | None,
              replays: Replays | None = None) -> Message | None:
        """The message of a valid sample of this run, vouched for by its producer, else None
        (counted: rejected when invalid, ignored with its reason otherwise)."""
        try:
            message = decode(payload, kind)
        except ProtoError as exc:
            self.reject(key, exc.reason)
            return None
        header = message.header
        if header.stream_id != self.stream:
            self.reject(key, f"message of stream {header.stream_id!r} on this stream's key")
            return None
        owner = owner_of(key)
        if owner is not None and header.producer != owner:
            return self.ignore("not its key's owner")
        if self.run_id and header.run_id != self.run_id and not (
                message.KIND == "status" and not header.run_id):  # of a service of any run
            return self.ignore("another run")
        if self.keyring:
            problem = self.keyring.problem(payload, message)
            if problem:
                return self.ignore(problem)
            if abs(time.time_ns() - header.publish_time_ns) > MAX_AGE_S * 1e9:
                return self.ignore("stale")
            if (self.floors and below_floor(message, self.floors)) or (
                    header.publish_time_ns < self.since_ns and message.KIND in FLOORED):
                return self.ignore("before the restart")
            if replays is not None and not replays.first(message):
                return self.ignore("replayed")
        return message

    def subscribing(self) -> None:
        """A holder is about to subscribe: in a restarted process, the first time, nothing
        published before now is this process's to answer."""
        if self.restarted and not self.since_ns:
            self.since_ns = time.time_ns()

    def ignore(self, reason: str) -> None:
        """Count one well-formed message ignored for ``reason`` (one of :data:`.trust.IGNORED`)."""
        self.stats.ignore(reason)


class _Holder:
    """Subscriber side shared by the holders: screening and, for a consumer that must see
    every frame (``count_lost``), the gaps in the frame numbering."""

    def __init__(self, screen: Screen, key: str, kind: str | None, count_lost: bool = False
                 ) -> None:
        self.key = key
        self.kind = kind
        self.arrived: threading.Event | None = None
        """Set on every arrival, when given (a loop over several holders waits on it)."""
        self._screen = screen
        self._replays = Replays()
        self._numbering = (FrameNumbering(screen.stats, screen.restarted) if count_lost
                           else None)
        self._cond = threading.Condition()
        self._woken = False

    def _screened(self, sample: Any) -> Received | None:
        key = str(sample.key_expr)
        payload = sample.payload.to_bytes()
        message = self._screen.check(payload, key, self.kind, self._replays)
        if message is None:
            return None
        if self._numbering is not None:
            self._numbering.arrived(message.header)
        return Received(message, payload, key, time.time_ns())

    def push(self, sample: Any) -> None:
        """Zenoh callback."""
        got = self._screened(sample)
        if got is not None:
            with self._cond:
                self._keep(got)
                self._cond.notify_all()
            if self.arrived is not None:
                self.arrived.set()

    def _keep(self, got: Received) -> None:
        raise NotImplementedError

    def wake(self) -> None:
        """Make a waiting :meth:`Inbox.get` return None now (used when stopping)."""
        with self._cond:
            self._woken = True
            self._cond.notify_all()


class Inbox(_Holder):
    """The latest ``capacity`` screened messages of one key expression, oldest taken first.

    It has the semantics of ``zenoh.handlers.RingChannel`` (a full inbox
    overwrites its oldest message, counted as dropped), with a :meth:`get`
    that has a timeout and can be woken, which a blocked ``RingChannel.recv``
    cannot.
    """

    def __init__(self, screen: Screen, key: str, kind: str | None, capacity: int,
                 count_lost: bool = False) -> None:
        if capacity < 1:
            raise ValueError(f"inbox capacity must be at least 1, got {capacity}")
        super().__init__(screen, key, kind, count_lost)
        self.dropped = 0
        self._items: collections.deque[Received] = collections.deque(maxlen=capacity)

    def _keep(self, got: Received) -> None:
        if len(self._items) == self._items.maxlen:
            self.dropped += 1
            self._screen.stats.dropped += 1
        self._items.append(got)

    def pending(self) -> int:
        """Messages waiting to be taken."""
        with self._cond:
            return len(self._items)

    def get(self, timeout: float | None = None) -> Received | None:
        """Take the oldest message, counted in ``frames_in``; None on timeout or when woken."""
        deadline = None if timeout is None else time.monotonic() + timeout
        with self._cond:
            while not self._items and not self._woken:
                left = None if deadline is None else deadline - time.monotonic()
                if left is not None and left <= 0:
                    return None
                self._cond.wait(left)
            if self._woken:
                self._woken = False
                return None
            got = self._items.popleft()
        self._screen.stats.count_in(got.message.header)
        return got


class Latest(_Holder):
    """The last screened message of one key; older ones are replaced, counted as dropped."""

    def __init__(self, screen: Screen, key: str, kind: str | None) -> None:
        super().__init__(screen, key, kind)
        self._got: Received | None = None

    def _keep(self, got: Received) -> None:
        if self._got is not None:
            self._screen.stats.dropped += 1
        self._got = got

    def take(self) -> Received | None:
        """The last message, or None; it is not given twice."""
        with self._cond:
            got, self._got = self._got, None
        return got

    def peek(self) -> Message | None:
        """The last message without taking it."""
        with self._cond:
            return None if self._got is None else self._got.message


class Recent(_Holder):
    """The last ``size`` screened messages by ``(run id, frame index)``.

    ``compact(got)``, when given, is what is kept of each message (taken on arrival,
    outside the lock): a consumer that needs less than a whole frame keeps less.
    """

    def __init__(self, screen: Screen, key: str, kind: str | None, size: int,
                 compact: Callable[[Received], Received] | None = None) -> None:
        super().__init__(screen, key, kind)
        self.size = size
        self._compact = compact
        self._items: collections.OrderedDict[tuple[str, int], Received] = (
            collections.OrderedDict())
        self._newest: tuple[str | None, int] = (None, -1)
        """The run and the highest frame index kept so far."""

    def _screened(self, sample: Any) -> Received | None:
        got = super()._screened(sample)
        return got if got is None or self._compact is None else self._compact(got)

    def _keep(self, got: Received) -> None:
        h = got.message.header
        self._items[(h.run_id, h.frame_index)] = got
        self._newest = (h.run_id, max(h.frame_index, self._newest[1])
                        if h.run_id == self._newest[0] else h.frame_index)
        while len(self._items) > self.size:  # not a drop: a consumer that finds a message
            self._items.popitem(last=False)  # gone counts its own work as dropped

    def take(self, run_id: str, frame_index: int, timeout: float = 0.0, keep: bool = False
             ) -> Received | None:
        """The message of that frame, or None if never or no longer kept (``keep``: it stays
        kept, for the results of the frame's other faces).

        With a ``timeout`` (seconds), a message not yet kept is waited for
        that long (a result can arrive before the frame it belongs to: the
        two travel from different publishers), unless a later frame of its run
        has come already (it will not); a wake stops the wait.
        """
        key = (run_id, frame_index)
        deadline = time.monotonic() + timeout
        with self._cond:
            while (key not in self._items and not self._woken
                   and not (self._newest[0] == run_id and self._newest[1] > frame_index)):
                left = deadline - time.monotonic()
                if left <= 0:
                    break
                self._cond.wait(left)
            return self._items.get(key) if keep else self._items.pop(key, None)
