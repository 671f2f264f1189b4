"""Plumbing every aamtrack service shares: options, process set-up, the bus session.

A service is one process with one Zenoh session. This module gives it:

- :class:`BusOptions`, :func:`add_bus_arguments`, :func:`service_parser`: the
  stream id and Zenoh endpoints, from the command line or the environment
  (``AAMTRACK_STREAM``, ``AAMTRACK_ZENOH_MODE``, ``AAMTRACK_ZENOH_LISTEN``,
  ``AAMTRACK_ZENOH_CONNECT``; endpoint lists comma-separated).
- :func:`init_process`: one thread for OpenMP and OpenCV, logging.
- :class:`Service`: the session as a context manager. :meth:`Service.ready`
  declares the liveliness token ``alive_key(stream, name)``; it publishes a ``Status`` on
  ``status_key(stream, name)`` every second with the counts in
  :class:`ServiceStats`, turns SIGTERM and SIGINT into :attr:`Service.stopping`,
  counts and logs (once per reason) every rejected message, and undeclares
  everything and closes the session on exit, so that no process hangs.
- :class:`Inbox`: the latest few messages of one key, for consumers slower
  than their input.
- :func:`image_of`: the pixels of a ``Frame`` or ``Overlay``, raw or JPEG.

A minimal service::

    def main(argv=None) -> int:
        args = service_parser("pose", "Head pose from fits.").parse_args(argv)
        init_process("pose", args.verbose)
        with Service("pose", BusOptions.from_args(args)) as svc:
            fits = svc.inbox("fit", capacity=4)
            svc.ready()
            while not svc.stopping:
                got = fits.get(timeout=0.5)
                if got is not None:
                    svc.publish(make_pose(svc, got.message))
        return 0

Counting rule (what the status counts mean): ``frames_in`` counts valid
messages taken from inboxes (or counted with :meth:`ServiceStats.count_in`),
``frames_out`` messages published with ``count=True``, ``dropped`` messages
overwritten in an inbox before they were taken plus those a service drops
itself, ``rejected`` messages that failed to decode.
"""

from __future__ import annotations

import argparse
import collections
import logging
import math
import os
import re
import signal
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from proto import Header, Message, ProtoError, Status, decode, encode
from proto.keys import TOPICS, alive_key, check_name, topic_key
from proto.messages import STATES, Frame, Overlay
from proto.zenoh_config import MODES, config_from_file, zenoh_config

ENV_STREAM = "AAMTRACK_STREAM"
ENV_MODE = "AAMTRACK_ZENOH_MODE"
ENV_LISTEN = "AAMTRACK_ZENOH_LISTEN"
ENV_CONNECT = "AAMTRACK_ZENOH_CONNECT"
ENV_CONFIG = "AAMTRACK_ZENOH_CONFIG"
ENV_RESTARTS = "AAMTRACK_RESTARTS"
"""Set by a supervisor to the number of times it restarted the service."""
DEFAULT_STREAM = "cam0"
STATUS_PERIOD = 1.0
"""Seconds between two status messages of a service."""
LATENCY_WINDOW = 300
"""Latencies kept for the status percentiles (about 10 s of video)."""
MAX_LOGGED_REASONS = 64
"""Distinct rejection reasons logged per service; later ones are only counted."""

_log = logging.getLogger("aamtrack.runtime")


def _env_list(name: str) -> tuple[str, ...]:
    return tuple(item.strip() for item in os.environ.get(name, "").split(",") if item.strip())


@dataclass(frozen=True)
class BusOptions:
    """Where a service connects: the stream id and the Zenoh session settings.

    Parameters
    ----------
    stream : str
        Stream id, a key chunk (``proto.keys.check_name``).
    mode : {"peer", "client", "router"}
    listen, connect : tuple of str
        Zenoh endpoints such as ``"tcp/127.0.0.1:7447"``.
    config_file : str
        A Zenoh JSON5 configuration (e.g. ``deploy/zenoh/client-tls.json5``
        for TLS); ``mode`` and any endpoints given here override its own.
    """

    stream: str = DEFAULT_STREAM
    mode: str = "peer"
    listen: tuple[str, ...] = ()
    connect: tuple[str, ...] = ()
    config_file: str = ""

    def __post_init__(self) -> None:
        try:
            check_name(self.stream)
        except ProtoError as exc:
            raise ValueError(str(exc)) from None
        if self.mode not in MODES:
            raise ValueError(f"zenoh mode {self.mode!r} is not one of {list(MODES)}")

    @classmethod
    def from_env(cls) -> BusOptions:
        """Options from the ``AAMTRACK_*`` environment variables (defaults where unset)."""
        return cls(
            stream=os.environ.get(ENV_STREAM, DEFAULT_STREAM),
            mode=os.environ.get(ENV_MODE, "peer"),
            listen=_env_list(ENV_LISTEN),
            connect=_env_list(ENV_CONNECT),
            config_file=os.environ.get(ENV_CONFIG, ""),
        )

    @classmethod
    def from_args(cls, args: argparse.Namespace) -> BusOptions:
        """Options from :func:`add_bus_arguments` arguments; the environment fills gaps."""
        env = cls.from_env()
        return cls(
            stream=args.stream or env.stream,
            mode=args.mode or env.mode,
            listen=tuple(args.listen) if args.listen else env.listen,
            connect=tuple(args.connect) if args.connect else env.connect,
            config_file=getattr(args, "zenoh_config", None) or env.config_file,
        )

    def argv(self) -> list[str]:
        """The command-line arguments that give these options back."""
        out = ["--stream", self.stream, "--mode", self.mode]
        for endpoint in self.listen:
            out += ["--listen", endpoint]
        for endpoint in self.connect:
            out += ["--connect", endpoint]
        if self.config_file:
            out += ["--zenoh-config", self.config_file]
        return out

    def config(self) -> Any:
        """The ``zenoh.Config``: from ``config_file`` when given, else multicast
        scouting off and the explicit endpoints."""
        if self.config_file:
            return config_from_file(self.config_file, self.mode, self.listen, self.connect)
        return zenoh_config(self.mode, self.listen, self.connect)


def add_bus_arguments(parser: argparse.ArgumentParser, verbose: bool = True) -> None:
    """Add ``--stream``, ``--mode``, ``--listen``, ``--connect`` and (optionally) ``--verbose``."""
    group = parser.add_argument_group("bus")
    group.add_argument("--stream", help=f"stream id (env {ENV_STREAM}, default {DEFAULT_STREAM})")
    group.add_argument("--mode", choices=MODES, help=f"zenoh mode (env {ENV_MODE}, default peer)")
    group.add_argument(
        "--listen", action="append", metavar="ENDPOINT",
        help=f"zenoh listen endpoint, repeatable (env {ENV_LISTEN}, comma-separated)",
    )
    group.add_argument(
        "--connect", action="append", metavar="ENDPOINT",
        help=f"zenoh endpoint to connect to, repeatable (env {ENV_CONNECT}, comma-separated)",
    )
    group.add_argument(
        "--zenoh-config", metavar="FILE",
        help=f"zenoh JSON5 configuration, e.g. TLS (env {ENV_CONFIG}); --mode and endpoints "
        "given override it",
    )
    if verbose:
        group.add_argument("-v", "--verbose", action="store_true", help="log debug messages")


def service_parser(name: str, description: str) -> argparse.ArgumentParser:
    """An argument parser for service ``name`` with the bus arguments already added."""
    parser = argparse.ArgumentParser(prog=f"aamtrack service {name}", description=description)
    add_bus_arguments(parser)
    return parser


def init_process(name: str, verbose: bool = False) -> logging.Logger:
    """Set up a service process: one compute thread, logging; return its logger.

    ``OMP_NUM_THREADS`` only takes effect before numpy's first import, so the
    launcher sets it in the environment of the processes it spawns as well.
    """
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    import cv2

    cv2.setNumThreads(1)
    root = logging.getLogger()
    if not root.handlers:
        logging.basicConfig(
            level=logging.DEBUG if verbose else logging.INFO,
            format=f"%(asctime)s {name}[%(process)d] %(levelname)s %(message)s",
        )
    elif verbose:
        root.setLevel(logging.DEBUG)
    import zenoh

    zenoh.init_log_from_env_or("error")
    return logging.getLogger(f"aamtrack.{name}")


class LatencyWindow:
    """The latest :data:`LATENCY_WINDOW` latencies, in milliseconds."""

    def __init__(self, size: int = LATENCY_WINDOW) -> None:
        self._values: collections.deque[float] = collections.deque(maxlen=size)

    def add(self, ms: float) -> None:
        """Record one latency in milliseconds."""
        self._values.append(float(ms))

    def percentiles(self) -> tuple[float, float]:
        """``(p50, p99)`` in milliseconds; NaN before any value."""
        if not self._values:
            return math.nan, math.nan
        p50, p99 = np.percentile(np.fromiter(self._values, float), [50, 99])
        return float(p50), float(p99)



@dataclass
class ServiceStats:
    """Counts a service publishes in its status (see the module's counting rule)."""

    frames_in: int = 0
    frames_out: int = 0
    dropped: int = 0
    rejected: int = 0
    last_frame: int = 0
    last_capture_ns: int = 0
    latency: LatencyWindow = field(default_factory=LatencyWindow)

    def count_in(self, header: Header | None = None) -> None:
        """Count one message received, remembering its frame index."""
        self.frames_in += 1
        if header is not None:
            self.last_frame = header.frame_index
            self.last_capture_ns = header.capture_time_ns


@dataclass(frozen=True)
class Received:
    """A message taken from an :class:`Inbox`.

    Attributes
    ----------
    message : Message
        The decoded, validated message.
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


class Inbox:
    """The latest ``capacity`` samples of one key expression, decoded when taken.

    It has the semantics of ``zenoh.handlers.RingChannel`` (a full inbox
    overwrites its oldest sample), with two things that channel lacks: a
    :meth:`get` with a timeout (a blocked ``RingChannel.recv`` cannot be
    interrupted, so a service could not stop), and a count of the samples
    overwritten (:attr:`dropped`). Samples are decoded in :meth:`get`, so a
    dropped frame costs no decoding.

    Parameters
    ----------
    service : Service
        Owner; counts go into its :class:`ServiceStats`.
    key : str
        Key expression subscribed to.
    kind : str, optional
        Expected message kind; anything else is rejected.
    capacity : int
        Samples kept.
    """

    def __init__(self, service: Service, key: str, kind: str | None, capacity: int) -> None:
        if capacity < 1:
            raise ValueError(f"inbox capacity must be at least 1, got {capacity}")
        self.key = key
        self.kind = kind
        self.dropped = 0
        self._service = service
        self._items: collections.deque[tuple[Any, int]] = collections.deque(maxlen=capacity)
        self._cond = threading.Condition()
        self._woken = False

    def push(self, sample: Any) -> None:
        """Zenoh callback: keep ``sample``, overwriting the oldest when full."""
        with self._cond:
            if len(self._items) == self._items.maxlen:
                self.dropped += 1
                self._service.stats.dropped += 1
            self._items.append((sample, time.time_ns()))
            self._cond.notify()

    def wake(self) -> None:
        """Make a waiting :meth:`get` return ``None`` now (used when stopping)."""
        with self._cond:
            self._woken = True
            self._cond.notify_all()

    def pending(self) -> int:
        """Samples waiting to be taken."""
        with self._cond:
            return len(self._items)

    def get(self, timeout: float | None = None) -> Received | None:
        """Take the oldest kept sample that decodes; ``None`` on timeout or when woken.

        Samples that fail to decode are counted as rejected (logged once per
        reason) and skipped; each valid one is counted in ``frames_in``.
        """
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            with self._cond:
                while not self._items and not self._woken:
                    left = None if deadline is None else deadline - time.monotonic()
                    if left is not None and left <= 0:
                        return None
                    self._cond.wait(left)
                if self._woken:
                    self._woken = False
                    return None
                sample, received_ns = self._items.popleft()
            key = str(sample.key_expr)
            payload = sample.payload.to_bytes()
            message = self._service.decode(payload, self.kind, source=key)
            if message is not None:
                self._service.stats.count_in(message.header)
                return Received(message, payload, key, received_ns)


class Service:
    """A service's Zenoh session, liveliness token, status publisher and counters.

    Parameters
    ----------
    name : str
        Service name, a key chunk: ``fitter``, ``pose``, ...
    bus : BusOptions
    status_period : float
        Seconds between status messages.
    handle_signals : bool
        Turn SIGTERM and SIGINT into :attr:`stopping` (main thread only).

    Notes
    -----
    Use it as a context manager: ``__exit__`` publishes a last ``stopped``
    status, undeclares every subscriber, queryable, publisher and the token,
    and closes the session (a Zenoh callback left declared keeps a process
    alive at exit). Counts live in :attr:`stats`; :meth:`set_state` sets the
    state and message the next status carries.
    """

    def __init__(
        self,
        name: str,
        bus: BusOptions,
        status_period: float = STATUS_PERIOD,
        handle_signals: bool = True,
    ) -> None:
        self.name = check_name(name, "service")
        self.bus = bus
        self.stream = bus.stream
        self.stats = ServiceStats()
        self.log = logging.getLogger(f"aamtrack.{name}")
        self.restarts = int(os.environ.get(ENV_RESTARTS, "0") or 0)
        self.session: Any = None
        self._status_period = status_period
        self._handle_signals = handle_signals
        self._stop = threading.Event()
        self._state = "starting"
        self._message = ""
        self._declared: list[Any] = []
        self._publishers: dict[str, Any] = {}
        self._inboxes: list[Inbox] = []
        self._reasons: set[str] = set()
        self._token: Any = None
        self._old_handlers: dict[int, Any] = {}
        self._status_thread: threading.Thread | None = None
        self._lock = threading.Lock()
        self.stop_hooks: list[Callable[[], None]] = []
        """Called (in the stopping thread) when the service is asked to stop."""

    # -- life cycle -------------------------------------------------------------------------

    def __enter__(self) -> Service:
        self.open()
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        if exc is not None and not isinstance(exc, KeyboardInterrupt):
            self.set_state("failed", f"{type(exc).__name__}: {exc}")
        self.close()

    def open(self) -> None:
        """Open the session and start publishing status (the token comes with :meth:`ready`)."""
        import zenoh

        if self._handle_signals and threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGTERM, signal.SIGINT):
                self._old_handlers[sig] = signal.signal(sig, self._on_signal)
        self.session = zenoh.open(self.bus.config())
        self._status_thread = threading.Thread(
            target=self._status_loop, name=f"{self.name}-status", daemon=True
        )
        self._status_thread.start()

    def close(self) -> None:
        """Publish a last status, undeclare everything, close the session. Idempotent."""
        if self.session is None:
            return
        self._stop.set()
        for inbox in self._inboxes:
            inbox.wake()
        if self._status_thread is not None:
            self._status_thread.join(timeout=2 * self._status_period + 1)
        if self._state != "failed":
            self._state = "stopped"
        session, self.session = self.session, None
        try:
            self._put_status(session)
        except Exception as exc:  # the session may already be broken; closing matters more
            self.log.debug("last status not published: %s", exc)
        finally:
            for item in [*self._declared, *self._publishers.values(), self._token]:
                _undeclare(item)
            self._declared.clear()
            self._publishers.clear()
            session.close()
            if threading.current_thread() is threading.main_thread():
                for sig, handler in self._old_handlers.items():
                    signal.signal(sig, handler)
                self._old_handlers.clear()

    def ready(self, message: str = "") -> None:
        """Declare the liveliness token and enter state ``running``.

        Call it once the service's subscribers and queryables are declared:
        a peer that waits for the token (:meth:`wait_for_alive`) may publish
        as soon as it appears. The status thread calls it after the first
        status period if the service has not.
        """
        with self._lock:
            if self._token is None and self.session is not None:
                key = alive_key(self.stream, self.name)
                self._token = self.session.liveliness().declare_token(key)
        if self._state == "starting":
            self.set_state("running", message)

    @property
    def stopping(self) -> bool:
        """Whether the service was asked to stop (signal or :meth:`request_stop`)."""
        return self._stop.is_set()

    def request_stop(self, reason: str = "") -> None:
        """Ask the service's loops to finish; wakes every inbox."""
        if reason:
            self.log.info("stopping: %s", reason)
        self._stop.set()
        for inbox in self._inboxes:
            inbox.wake()
        for hook in self.stop_hooks:
            hook()

    def wait(self, seconds: float) -> bool:
        """Sleep up to ``seconds``; return True early if stopping."""
        return self._stop.wait(seconds)

    def _on_signal(self, signum: int, frame: Any) -> None:
        self.request_stop(f"signal {signal.Signals(signum).name}")

    # -- bus ----------------------------------------------------------------------------------

    def key(self, kind: str) -> str:
        """``aamtrack/<stream>/<kind>`` for a message kind of :data:`proto.keys.TOPICS`."""
        return topic_key(self.stream, kind)

    def header(self, frame_index: int, capture_time_ns: int | None = None) -> Header:
        """A header for a message this service publishes now."""
        return Header.now(self.stream, frame_index, self.name, capture_time_ns)

    def publish(self, message: Message, count: bool = True) -> None:
        """Encode ``message`` and put it on its key (counted in ``frames_out``)."""
        self.put(message.key(), encode(message))
        if count:
            self.stats.frames_out += 1

    def put(self, key: str, payload: bytes) -> None:
        """Put raw bytes on ``key`` through a publisher declared once per key."""
        publisher = self._publishers.get(key)
        if publisher is None:
            with self._lock:
                publisher = self._publishers.get(key)
                if publisher is None:
                    publisher = self.session.declare_publisher(key)
                    self._publishers[key] = publisher
        publisher.put(payload)

    def inbox(self, kind_or_key: str, capacity: int = 1, kind: str | None = None) -> Inbox:
        """Subscribe to a message kind of this stream (or a key expression) into an :class:`Inbox`.

        Parameters
        ----------
        kind_or_key : str
            A kind of :data:`proto.keys.TOPICS` (``"frame"``, ``"fit"``, ...)
            or a full key expression.
        capacity : int
            Latest samples kept; 1 for video frames.
        kind : str, optional
            Expected kind when ``kind_or_key`` is a key expression.
        """
        if kind_or_key in TOPICS:
            key, kind = self.key(kind_or_key), kind_or_key
        else:
            key = kind_or_key
        box = Inbox(self, key, kind, capacity)
        self._inboxes.append(box)
        self.subscribe(key, box.push)
        return box

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

    def decode(
        self, payload: bytes, kind: str | None = None, source: str = "bus"
    ) -> Message | None:
        """Decode a payload; on failure count it as rejected, log the reason once, return None."""
        try:
            return decode(payload, kind)
        except ProtoError as exc:
            self.reject(source, exc.reason)
            return None

    def reject(self, source: str, reason: str) -> None:
        """Count one rejected input and log its reason the first time that reason is seen.

        Reasons that differ only in numbers count as one (``payload of 2000000
        bytes ...`` and ``payload of 3000000 bytes ...``), so a flood of bad
        input gives a handful of log lines, and the total is in the status.
        """
        self.stats.rejected += 1
        shape = re.sub(r"\d+", "#", reason)[:200]
        if shape in self._reasons:
            return
        if len(self._reasons) < MAX_LOGGED_REASONS:
            self._reasons.add(shape)
            self.log.warning("rejected input from %s: %s", source, reason)
        elif len(self._reasons) == MAX_LOGGED_REASONS:
            self._reasons.add("")
            self.log.warning("more kinds of rejected input: counted in the status only")

    def wait_for_alive(self, services: Iterable[str], timeout: float) -> list[str]:
        """Wait until ``services`` of this stream hold liveliness tokens; return those missing."""
        wanted = set(services)
        deadline = time.monotonic() + timeout
        while wanted and not self.stopping:
            wanted -= alive_services(self.session, self.stream, timeout=0.5)
            if not wanted or time.monotonic() >= deadline:
                break
            self.wait(0.05)
        return sorted(wanted)

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
            frames_out=s.frames_out, dropped=s.dropped, rejected=s.rejected,
            latency_p50_ms=p50, latency_p99_ms=p99, restarts=self.restarts,
            message=self._message,
        )

    def _put_status(self, session: Any) -> None:
        status = self.status()
        session.put(status.key(), encode(status))

    def _status_loop(self) -> None:
        while not self._stop.wait(self._status_period):
            try:
                if self._token is None:
                    self.ready()
                self._put_status(self.session)
            except Exception as exc:  # keep the thread alive; the next period retries
                self.log.debug("status not published: %s", exc)


def alive_services(session: Any, stream: str, timeout: float = 1.0) -> set[str]:
    """Names of the services of ``stream`` that hold a liveliness token now."""
    from proto.keys import alive_wildcard

    names: set[str] = set()
    for reply in session.liveliness().get(alive_wildcard(stream), timeout=timeout):
        if reply.ok is not None:
            names.add(str(reply.ok.key_expr).rsplit("/", 1)[-1])
    return names


def _undeclare(item: Any) -> None:
    if item is None:
        return
    try:
        item.undeclare()
    except Exception as exc:  # already gone with a broken session; nothing left to free
        _log.debug("undeclare failed: %s", exc)


def image_of(message: Frame | Overlay) -> np.ndarray:
    """The pixels of a frame or overlay: ``(H, W, 3)`` BGR or ``(H, W)`` grey uint8.

    Raises
    ------
    ProtoError
        When JPEG data does not decode or decodes to another size than the
        message says.
    """
    if isinstance(message.image, np.ndarray):
        return message.image
    import cv2

    image = cv2.imdecode(np.frombuffer(message.image, np.uint8), cv2.IMREAD_UNCHANGED)
    if image is None:
        raise ProtoError(f"{message.KIND}.image: JPEG data does not decode")
    if image.shape[:2] != (message.height, message.width):
        raise ProtoError(
            f"{message.KIND}.image: JPEG is {image.shape[1]} x {image.shape[0]}, "
            f"message says {message.width} x {message.height}"
        )
    return image

