"""A service's Zenoh session: publishing, receiving, its loop, presence and status.

A minimal service::

    def main(argv=None) -> int:
        opts = parse(PoseOptions, argv)
        with Service("pose", opts.bus) as svc:
            for got in svc.messages("fit", capacity=8):
                svc.publish(make_pose(svc, got.message))
        return 0

:meth:`Service.messages` subscribes, screens every sample on arrival
(:mod:`services.bus.inbox`), declares the service ready, and yields each
valid message of the run, timing the work done on it; stop signals, the death
of the launcher and :meth:`Service.request_stop` end the loop.
"""

from __future__ import annotations

import logging
import os
import threading
from collections.abc import Callable
from typing import Any

from proto import Header, Message, Status, encode
from proto.auth import Keyring, RunKeys
from proto.codec import IMAGE_KINDS, encode_parts
from proto.keys import alive_key, check_name, topic_key
from proto.messages import STATES
from services.bus.connection import BusOptions
from services.bus.inbox import Screen
from services.bus.options import OptionError
from services.bus.presence import Presence
from services.bus.process import ENV_RESTARTS, StopWatch, release_memory
from services.bus.qos import MUST_ARRIVE, TOPIC_QOS, QoS
from services.bus.receiving import Receiving
from services.bus.shm import SharedImages
from services.bus.stats import ServiceStats
from services.bus.trust import inherited, inherited_floors, read_keys_file

STATUS_PERIOD = 1.0
"""Seconds between two status messages of a service."""
FLOOD = 200
"""Rejected or ignored messages that make a flood: once one is over (a status period
without more), the memory it made the allocator take is given back to the system, which
would otherwise keep it at its high-water mark (``malloc_trim`` stalls allocations for up
to a few hundred ms: never done on a schedule)."""

_log = logging.getLogger("aamtrack.bus")


class Service(Receiving, Presence):
    """A service's Zenoh session, liveliness token, status publisher and counters.

    Parameters
    ----------
    name : str
        Service name, a key chunk: ``fitter``, ``pose``, ...
    bus : BusOptions
    status_period : float
        Seconds between status messages.
    handle_signals : bool
        Turn SIGTERM, SIGINT and SIGHUP into a stop (main thread only).
    announce : bool
        Publish a status; False for tools beside the stack (``echo``,
        ``record``), which must not show up among its services.
    keyring : Keyring, optional
        The run's keys this process holds (:mod:`proto.auth`): every message it publishes
        is signed with its own, and every message it receives must be signed by its
        producer. By default those the launcher handed the process
        (:func:`services.bus.trust.inherited`); none: nothing is signed or checked.

    Notes
    -----
    Use it as a context manager: leaving it publishes a last status (that
    must arrive), undeclares every subscriber, queryable, publisher and the
    token, and closes the session (a Zenoh callback left declared keeps a
    process alive at exit).
    """

    def __init__(self, name: str, bus: BusOptions, status_period: float = STATUS_PERIOD,
                 handle_signals: bool = True, announce: bool = True,
                 keyring: Keyring | None = None) -> None:
        self.name = check_name(name, "service")
        self.bus = bus
        self.stream = bus.stream
        self.run_id = bus.run_id
        self.stats = ServiceStats()
        self.log = logging.getLogger(f"aamtrack.{name}")
        self.restarts = int(os.environ.get(ENV_RESTARTS, "0") or 0)
        self.session: Any = None
        self.keyring = keyring if keyring is not None else _keyring_of(bus, self.name)
        if self.keyring and self.keyring.signer != self.name:
            self.keyring = self.keyring.public_only()  # checks only: the key is another's
        self.run_keys: RunKeys | None = None
        """The run's keys as its launcher vouched for them, fetched by ``--trust``."""
        self.screen = Screen(self.stream, self.run_id, self.stats, self.reject, self.keyring,
                             self.restarts > 0, inherited_floors() if keyring is None else None)
        self.shared_memory = True
        """Whether the host gives the session shared memory (:meth:`_open_session`)."""
        self.images: SharedImages | None = None
        """Where the service's image messages are written (:meth:`share_images`)."""
        self.stop_hooks: list[Callable[[], None]] = []
        """Called (in the stopping thread) when the service is asked to stop."""
        self._status_period = status_period
        self._announce = announce
        self._watch = StopWatch(self.request_stop, handle_signals)
        self._stop = threading.Event()
        self._state, self._message = "starting", ""
        self._declared: list[Any] = []
        self._publishers: dict[str, Any] = {}
        self._holders: list[Any] = []
        self._reasons: set[str] = set()
        self._token: Any = None
        self._alive: set[str] = set()
        self._vouched: set[str] = set()
        self._watching = False
        self._status_thread: threading.Thread | None = None
        self._lock = threading.Lock()

    # -- life cycle -------------------------------------------------------------------------

    def __enter__(self) -> Service:
        self.open()
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        if exc is not None and not isinstance(exc, KeyboardInterrupt):
            self.set_state("failed", f"{type(exc).__name__}: {exc}")
        self.close()

    def open(self) -> None:
        """Open the session and start publishing status (the token comes with :meth:`ready`).

        Raises
        ------
        OptionError
            When the session cannot be opened (an endpoint in use, a bad configuration).
        """
        import zenoh

        try:
            self.session = self._open_session()
        except zenoh.ZError as exc:
            raise OptionError(f"cannot open the Zenoh session ({self.bus.mode}, listen "
                              f"{list(self.bus.listen)}, connect {list(self.bus.connect)}): "
                              f"{exc}") from None
        self._watch.start()
        if not self.keyring and self.bus.trust:
            self.trust_run(self.bus.trust)
        if self._announce:
            self._status_thread = threading.Thread(
                target=self._status_loop, name=f"{self.name}-status", daemon=True)
            self._status_thread.start()

    def _open_session(self) -> Any:
        """The Zenoh session; without shared memory where the host has none (no ``/dev/shm``,
        or not writable): one warning, and everything goes over the network."""
        import zenoh

        config = self.bus.config()
        try:
            return zenoh.open(config)
        except zenoh.ZError as exc:
            if "shm" not in str(exc).lower():
                raise
            self.log.warning("no shared memory (%s): images go over the network instead "
                             "(counted)", exc)
        self.shared_memory = False
        config.insert_json5("transport/shared_memory/enabled", "false")
        return zenoh.open(config)

    def close(self) -> None:
        """Publish a last status, undeclare everything, close the session. Idempotent."""
        if self.session is None:
            return
        self._stop.set()
        self._watch.close()
        for holder in self._holders:
            holder.wake()
        if self._status_thread is not None:
            self._status_thread.join(timeout=2 * self._status_period + 1)
        if self._state != "failed":
            self._state = "stopped"
        with self._lock:
            session, self.session = self.session, None
        try:
            if self._announce:
                status = self.status()
                session.put(status.key(), self.encode(status), **MUST_ARRIVE.publisher_kwargs())
        except Exception as exc:  # the session may already be broken; closing matters more
            self.log.debug("last status not published: %s", exc)
        finally:
            for item in [*self._declared, *self._publishers.values(), self._token]:
                _undeclare(item)
            self._declared.clear()
            self._publishers.clear()
            session.close()

    def ready(self, message: str = "") -> None:
        """Declare the liveliness token and enter state ``running`` (idempotent).

        Call it once the service's subscribers and queryables are declared:
        a peer that waits for the token may publish as soon as it appears.
        """
        with self._lock:
            if self._token is None and self.session is not None:
                self._token = self.session.liveliness().declare_token(
                    alive_key(self.stream, self.name))
        if self._state == "starting":
            self.set_state("running", message or None)
        self._publish_status()  # now, not a period later: peers may wait for it


    @property
    def stopping(self) -> bool:
        """Whether the service was asked to stop (signal, launcher gone or :meth:`request_stop`)."""
        return self._stop.is_set()

    def request_stop(self, reason: str = "") -> None:
        """Ask the service's loops to finish; wakes every holder."""
        if reason:
            self.log.info("stopping: %s", reason)
        self._stop.set()
        for holder in self._holders:
            holder.wake()
        for hook in self.stop_hooks:
            hook()

    def wait(self, seconds: float) -> bool:
        """Sleep up to ``seconds``; return True early if stopping."""
        return self._stop.wait(seconds)

    # -- publishing ---------------------------------------------------------------------------

    def key(self, kind: str) -> str:
        """``aamtrack/<stream>/<kind>`` for a message kind of :data:`proto.keys.TOPICS`."""
        return topic_key(self.stream, kind)

    def header(self, frame_index: int, capture_time_ns: int | None = None,
               run_id: str | None = None, media_time_ns: int = 0) -> Header:
        """A header for a message this service publishes now (of its own run by default)."""
        run = self.run_id if run_id is None else run_id
        return Header.now(self.stream, frame_index, self.name, capture_time_ns, run,
                          media_time_ns)

    def header_for(self, source: Message) -> Header:
        """A header for the result of ``source``: its frame, capture and media times, run."""
        h = source.header
        return self.header(h.frame_index, h.capture_time_ns, h.run_id, h.media_time_ns)

    def encode(self, message: Message) -> bytes:
        """``message`` encoded, and signed with this service's key when it has one."""
        return self.keyring.encode(message) if self.keyring.signer else encode(message)

    def publish(self, message: Message, count: bool = True) -> None:
        """Encode ``message`` (signed: :meth:`encode`) and put it on its key with its
        topic's QoS; an image written once into the service's shared memory when it has
        some (:attr:`images`)."""
        if self.images is not None and message.KIND in IMAGE_KINDS:
            parts = (self.keyring.encode_parts(message) if self.keyring.signer
                     else encode_parts(message))
            payload: Any = self.images.payload(parts)
        else:
            payload = self.encode(message)
        self.put(message.key(), payload, TOPIC_QOS.get(message.KIND, QoS()))
        if count:
            self.stats.frames_out += 1

    def share_images(self, images: int) -> SharedImages:
        """Write this service's frames or overlays once into a shared-memory pool holding
        ``images`` of them (0: over the network); see :mod:`services.bus.shm`."""
        self.images = SharedImages(images, self.log, available=self.shared_memory)
        return self.images

    def put(self, key: str, payload: Any, qos: QoS | None = None) -> None:
        """Put a payload (bytes or ``zenoh.ZBytes``) on ``key`` through a publisher declared
        once per key (with ``qos``).

        Once the service is closed (a callback thread may still answer while it
        stops) nothing is sent.
        """
        publisher = self._publishers.get(key)
        if publisher is None:
            with self._lock:
                if self.session is None:
                    return
                publisher = self._publishers.get(key)
                if publisher is None:
                    settings = (qos or QoS()).publisher_kwargs()
                    publisher = self.session.declare_publisher(key, **settings)
                    self._publishers[key] = publisher
        try:
            publisher.put(payload)
        except Exception:  # zenoh.ZError of a publisher undeclared by close() meanwhile
            if self.session is not None:
                raise

    # -- status -------------------------------------------------------------------------------

    @property
    def state(self) -> str:
        return self._state

    def set_state(self, state: str, message: str | None = None) -> None:
        """Set the state (one of ``proto.messages.STATES``) and optionally the status message."""
        if state not in STATES:
            raise ValueError(f"state {state!r} is not one of {list(STATES)}")
        self._state = state
        if message is not None:
            self._message = message[:1000]

    def status(self) -> Status:
        """The status message for the current counts."""
        p50, p99 = self.stats.latency.percentiles()
        s = self.stats
        return Status(
            self.header(s.last_frame, s.last_capture_ns or None),
            service=self.name, state=self._state, frames_in=s.frames_in,
            frames_out=s.frames_out, dropped=s.dropped, rejected=s.rejected, lost=s.lost,
            ignored=s.ignored, failed=s.failed, latency_p50_ms=p50, latency_p99_ms=p99,
            restarts=self.restarts, message=self._message,
        )

    def _publish_status(self) -> None:
        if not self._announce:
            return
        try:
            status = self.status()
            self.put(status.key(), self.encode(status), TOPIC_QOS["status"])
        except Exception as exc:  # keep the thread alive; the next period retries
            self.log.debug("status not published: %s", exc)

    def _status_loop(self) -> None:
        trimmed = last = 0
        while not self._stop.wait(self._status_period):
            self._publish_status()
            bad = self.stats.rejected + self.stats.ignored
            if bad - trimmed >= FLOOD and bad == last:  # a flood, over for a period now
                release_memory()
                trimmed = bad
            last = bad

    def trust_run(self, trust: str = "", timeout: float = 10.0) -> RunKeys:
        """Check everything received from now on against the run's public keys, as its
        launcher publishes them (:func:`services.bus.run_keys.fetch_run_keys`); only that
        run's messages pass.

        Raises
        ------
        OptionError
            When no launcher answers, or none that ``trust`` names, or several do.
        """
        from services.bus.run_keys import RunKeysError, fetch_run_keys

        try:
            self.run_keys = fetch_run_keys(self.session, self.stream, trust, timeout,
                                           self.wait)
        except RunKeysError as exc:
            self.close()
            raise OptionError(str(exc)) from None
        self.keyring = self.run_keys.keyring
        self.screen.keyring = self.keyring
        if self.run_keys.run_id and not self.run_id:
            self.run_id = self.screen.run_id = self.run_keys.run_id
        return self.run_keys


def _keyring_of(bus: BusOptions, name: str) -> Keyring:
    """The keys of a service: from its ``--keys`` file, else those handed to the process."""
    if not bus.keys:
        return inherited()
    try:
        return read_keys_file(bus.keys, name)
    except ValueError as exc:
        raise OptionError(f"--keys: {exc}") from None


def _undeclare(item: Any) -> None:
    if item is None:
        return
    try:
        item.undeclare()
    except Exception as exc:  # already gone with a broken session; nothing left to free
        _log.debug("undeclare failed: %s", exc)
