"""Receiving: subscriptions into screened holders, the service loop, queries, rejections.

A mixin of :class:`services.bus.session.Service`, which provides the
session, the screen, the counts and the stop state it uses.
"""

from __future__ import annotations

import contextlib
import re
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

from proto import Message, ProtoError, decode
from proto.keys import TOPICS, topic_key
from services.bus.frames import FRAMES_KEPT, MAX_BYTES, FrameStore, pixels_only
from services.bus.inbox import Inbox, Latest, Received, Recent, Screen
from services.bus.qos import TOPIC_QOS
from services.bus.stats import ServiceStats

POLL_S = 0.5
"""Longest wait of a message loop before it looks whether it must stop."""
MAX_LOGGED_REASONS = 64
"""Distinct rejection reasons logged per service; later ones are only counted."""


class Receiving:
    """Subscriptions, holders, the service loop and rejection accounting of a service."""

    session: Any
    stream: str
    screen: Screen
    stats: ServiceStats
    log: Any
    _holders: list[Any]
    _declared: list[Any]
    _reasons: set[str]

    @property
    def stopping(self) -> bool:
        raise NotImplementedError

    def ready(self, message: str = "") -> None:
        raise NotImplementedError

    def _key_and_kind(self, kind_or_key: str, kind: str | None) -> tuple[str, str | None]:
        if kind_or_key in TOPICS:
            return topic_key(self.stream, kind_or_key), kind_or_key
        return kind_or_key, kind

    def _hold(self, holder: Any) -> Any:
        self.screen.subscribing()
        self._holders.append(holder)
        self.subscribe(holder.key, holder.push)
        return holder

    def inbox(self, kind_or_key: str, capacity: int = 1, kind: str | None = None,
              count_lost: bool = False) -> Inbox:
        """The latest ``capacity`` messages of a kind of this stream (or a key expression)."""
        key, kind = self._key_and_kind(kind_or_key, kind)
        return self._hold(Inbox(self.screen, key, kind, capacity, count_lost))

    def latest(self, kind: str) -> Latest:
        """The last message of a kind of this stream."""
        return self._hold(Latest(self.screen, topic_key(self.stream, kind), kind))

    def recent(self, kind: str, size: int,
               compact: Callable[[Received], Received] | None = None) -> Recent:
        """The last ``size`` messages of a kind of this stream, by frame (each as
        ``compact`` makes it, when given)."""
        return self._hold(Recent(self.screen, topic_key(self.stream, kind), kind, size,
                                 compact))

    def frame_store(self, count: int = FRAMES_KEPT, max_bytes: int = MAX_BYTES,
                    compact: Callable[[Received], Received] | None = pixels_only) -> FrameStore:
        """This stream's frames, kept until no result for them can come
        (:class:`services.bus.frames.FrameStore`)."""
        return self._hold(FrameStore(self.screen, topic_key(self.stream, "frame"), count,
                                     max_bytes, compact))

    def messages(self, kind_or_key: str, capacity: int = 1, kind: str | None = None,
                 count_lost: bool = False) -> Iterator[Received]:
        """The service loop: each valid message of the run, until the service stops.

        Subscribes now, so call it before :meth:`ready` (a peer waiting for
        the service's token may publish at once); declares the service ready
        when the loop starts if it is not yet; the time from yielding a
        message to asking for the next is its latency.
        """
        inbox = self.inbox(kind_or_key, capacity, kind, count_lost)

        def loop() -> Iterator[Received]:
            self.ready()
            while not self.stopping:
                got = inbox.get(timeout=POLL_S)
                if got is not None:
                    yield from self._timed(got)

        return loop()

    def messages_of(self, inputs: dict[str, tuple[str, int]], tick: float = POLL_S
                    ) -> Iterator[Received | None]:
        """The service loop over several inputs: ``{key or kind: (kind, capacity)}``.

        Each round takes what is waiting from each input in the given order;
        when nothing is waiting for ``tick`` seconds the loop yields None, so
        that the caller can look at its clocks.
        """
        arrived = threading.Event()
        inboxes = []
        for name, (kind, capacity) in inputs.items():
            inbox = self.inbox(name, capacity, kind)
            inbox.arrived = arrived
            inboxes.append(inbox)

        def loop() -> Iterator[Received | None]:
            self.ready()
            while not self.stopping:
                arrived.clear()
                took = False
                for inbox in inboxes:
                    while (got := inbox.get(timeout=0)) is not None:
                        took = True
                        yield from self._timed(got)
                if not took and not arrived.wait(tick):
                    yield None

        return loop()

    def _timed(self, got: Received) -> Iterator[Received]:
        started = time.perf_counter()
        yield got
        self.stats.latency.add(1000 * (time.perf_counter() - started))

    def subscribe(self, key: str, callback: Callable[[Any], None]) -> Any:
        """Declare a subscriber calling ``callback(sample)``; undeclared on close."""
        import zenoh

        sub = self.session.declare_subscriber(key, zenoh.handlers.Callback(callback))
        self._declared.append(sub)
        return sub

    def queryable(self, key: str, callback: Callable[[Any], None]) -> Any:
        """Declare a queryable calling ``callback(query)``; undeclared on close."""
        import zenoh

        qbl = self.session.declare_queryable(key, zenoh.handlers.Callback(callback))
        self._declared.append(qbl)
        return qbl

    def querier(self, key: str, timeout: float, every_reply: bool = False) -> Any:
        """Declare a querier of ``key`` with replies awaited ``timeout`` seconds; with
        ``every_reply``, queries reach every queryable of the key and each reply comes as it
        arrives (none replaces another), so the caller can take the first it trusts."""
        import zenoh

        qos = TOPIC_QOS["fit"].publisher_kwargs()
        if every_reply:
            qos |= {"target": zenoh.QueryTarget.ALL,
                    "consolidation": zenoh.ConsolidationMode.NONE}
        q = self.session.declare_querier(key, timeout=timeout, **qos)
        self._declared.append(q)
        return q

    def decode(self, payload: bytes, kind: str | None = None, source: str = "bus"
               ) -> Message | None:
        """Decode a payload; on failure count it as rejected, log the reason once, return None."""
        try:
            return decode(payload, kind)
        except ProtoError as exc:
            self.reject(source, exc.reason)
            return None

    @contextlib.contextmanager
    def answering(self, what: str) -> Iterator[None]:
        """The work on one message (``what`` names it): an unexpected error in it is counted
        as ``failed``, logged with its traceback the first time one of its shape is seen,
        and the service goes on with the next message."""
        try:
            yield
        except Exception as exc:  # whatever one message does, the service survives it
            self.stats.failed += 1
            reason = f"{type(exc).__name__}: {exc}"
            if self._first_of_shape("failed " + reason):
                self.log.exception("could not answer %s: %s", what, reason)

    def _first_of_shape(self, reason: str) -> bool:
        """Whether a reason of this shape (numbers aside) is new and may be logged."""
        shape = re.sub(r"\d+", "#", reason)[:200]
        if shape in self._reasons:
            return False
        if len(self._reasons) < MAX_LOGGED_REASONS:
            self._reasons.add(shape)
            return True
        if len(self._reasons) == MAX_LOGGED_REASONS:
            self._reasons.add("")
            self.log.warning("more kinds of rejected or failed input: counted in the status "
                             "only")
        return False

    def reject(self, source: str, reason: str) -> None:
        """Count one rejected input; log its reason the first time a reason of its shape is seen.

        Reasons that differ only in numbers count as one, so a flood of bad
        input gives a handful of log lines; the total is in the status.
        """
        self.stats.rejected += 1
        if self._first_of_shape(reason):
            self.log.warning("rejected input from %s: %s", source, reason)
