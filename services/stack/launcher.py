"""``aamtrack run``: the whole stack on one host, from a video to end of stream.

The launcher

1. checks the input and trains (or finds in the cache) the models the
   services need, so that no service trains while the video plays;
2. opens its own Zenoh session in peer mode listening on ``--endpoint``
   (``tcp/127.0.0.1:7447`` when free, else a free loopback port); every
   service connects to it and listens on a port of its own, and Zenoh's
   gossip joins them into a mesh (no router, multicast scouting off);
3. starts each service as its own process (spawn start method, see
   :mod:`services.stack.supervisor`), the source last, once the others hold their
   liveliness tokens;
4. watches the results and the services' status, restarting a service that
   dies; after end of stream it waits until the last frame's results are in
   and the bus has gone quiet;
5. stops every process (SIGTERM, then SIGKILL after a timeout), prints a
   summary and returns 0, or non-zero with a message when the input failed,
   a service could not be kept running, or it was interrupted.
"""

from __future__ import annotations

import json
import logging
import math
import socket
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from proto import EndOfStream, Status
from proto.keys import status_wildcard
from services.bus.runtime import BusOptions, Service
from services.stack.recorder import IMAGE_KINDS, RESULT_KINDS, RecordWriter
from services.stack.supervisor import SERVICE_MODULES, ServiceSpec, Supervisor

log = logging.getLogger("aamtrack.launcher")
NAME = "launcher"
EXIT_OK, EXIT_FAILED, EXIT_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130
FINAL_STATUS_WAIT = 2.0
"""Seconds to wait, once the processes are gone, for their last status messages."""
BEST_EFFORT = {"ar": 5, "rerun": 5}
"""Niceness of the stages off the capture-to-pose path: they yield the CPU to it."""
SERVICE_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
"""One compute thread per service process: many processes share few cores."""


@dataclass
class StackOptions:
    """What ``aamtrack run`` was asked to do (see ``services.cli.run_cmd`` for each option)."""

    video: str | None = None
    camera: int | None = None
    url: str | None = None
    stream: str = "cam0"
    pace: str = "realtime"
    loop: int = 1
    jpeg: int = 0
    window: int = 2
    max_frames: int = 0
    warp: str = "auto"
    algorithm: str | None = None
    model: str | None = None
    model_limit: int = 0
    model_images: int = 30
    classifier: str | None = None
    fov: float = 60.0
    calibration: str | None = None
    ar: bool = True
    rrd: str | None = None
    rerun_port: int | None = None
    endpoint: str | None = None
    """Zenoh endpoint the launcher listens on; :func:`default_endpoint` if None."""
    record: str | None = None
    record_images: bool = False
    summary: str | None = None
    restart: bool = True
    start_timeout: float = 120.0
    drain_quiet: float = 0.75
    drain_max: float = 20.0
    verbose: bool = False
    extra: dict[str, list[str]] = field(default_factory=dict)
    """Extra arguments per service name, appended to its command line."""


DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"
"""Where the launcher listens when that port is free (``echo`` and ``record`` connect there)."""


def default_endpoint() -> str:
    """:data:`DEFAULT_ENDPOINT` if its port is free, else a free loopback port."""
    port = int(DEFAULT_ENDPOINT.rsplit(":", 1)[1])
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        # Connections of an earlier run in TIME_WAIT do not make the port busy.
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return f"tcp/127.0.0.1:{free_port()}"
    return DEFAULT_ENDPOINT


def free_port() -> int:
    """A TCP port free on 127.0.0.1 now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def input_argv(opts: StackOptions) -> list[str]:
    """The source's input arguments."""
    if opts.video is not None:
        return ["--video", str(opts.video)]
    if opts.camera is not None:
        return ["--camera", str(opts.camera)]
    if opts.url is not None:
        return ["--url", opts.url]
    raise ValueError("give a video file, a camera or a stream URL")


def check_input(opts: StackOptions) -> None:
    """Open the input once to fail early with a clear message.

    Raises
    ------
    services.source.capture.SourceError
    """
    if opts.video is None:
        return  # cameras and streams are opened by the source, which reports failures
    from services.source.capture import InputSpec, VideoInput

    VideoInput(InputSpec(video=opts.video)).close()


def prepare_models(opts: StackOptions) -> dict[str, list[str]]:
    """Train or find the cached models; the arguments that point services at them."""
    from services.fitter.service import build_parser, model_path

    fit_args = build_parser().parse_args(_model_argv(opts))
    path = model_path(fit_args)
    argv = {"fitter": ["--model", str(path)]}
    try:
        from aamcore.expression.training import classifier_argv
    except ImportError:
        return argv
    argv["expression"] = classifier_argv(path, opts.classifier)
    return argv


def _model_argv(opts: StackOptions) -> list[str]:
    argv = ["--model-images", str(opts.model_images)]
    if opts.model:
        argv += ["--model", opts.model]
    if opts.model_limit:
        argv += ["--model-limit", str(opts.model_limit)]
    return argv


def module_exists(module: str) -> bool:
    """Whether ``module`` can be imported (its file exists)."""
    import importlib.util

    try:
        return importlib.util.find_spec(module) is not None
    except ModuleNotFoundError:
        return False


def service_specs(opts: StackOptions, bus: BusOptions, models: dict[str, list[str]]) -> list[
        ServiceSpec]:
    """The processes of the stack, the source last."""
    common = bus.argv() + (["--verbose"] if opts.verbose else [])
    wanted: dict[str, list[str]] = {
        "detector": [],
        "fitter": ["--warp", opts.warp, *models.get("fitter", []),
                   *(["--algorithm", opts.algorithm] if opts.algorithm else [])],
        "pose": (["--calibration", opts.calibration] if opts.calibration
                 else ["--fov", str(opts.fov)]),
        "expression": models.get("expression", []),
    }
    if opts.ar:
        wanted["ar"] = []
    if opts.rrd or opts.rerun_port:
        wanted["rerun"] = ((["--rrd", opts.rrd] if opts.rrd else [])
                           + (["--serve", str(opts.rerun_port)] if opts.rerun_port else []))
    specs = []
    for name, argv in wanted.items():
        module = SERVICE_MODULES[name]
        if not module_exists(module):
            log.warning("not starting %s: module %s does not exist yet", name, module)
            continue
        specs.append(ServiceSpec(name, module, common + argv + opts.extra.get(name, []),
                                 restart=opts.restart, nice=BEST_EFFORT.get(name, 0)))
    waits = ",".join(s.name for s in specs)
    source_argv = [*input_argv(opts), "--pace", opts.pace, "--loop", str(opts.loop),
                   "--jpeg", str(opts.jpeg), "--window", str(opts.window),
                   "--max-frames", str(opts.max_frames), "--wait-for", waits,
                   "--wait-timeout", str(opts.start_timeout)]
    specs.append(ServiceSpec("source", SERVICE_MODULES["source"],
                             common + source_argv + opts.extra.get("source", []),
                             restart=False))
    return specs


class StackMonitor:
    """What the launcher sees on the bus: results per frame, statuses, end of stream."""

    def __init__(self, svc: Service, recorder: RecordWriter | None, record_images: bool) -> None:
        self.svc = svc
        self.recorder = recorder
        self.indices: dict[str, set[int]] = {k: set() for k in ("fit", "pose", "expression")}
        self.counts: dict[str, int] = {k: 0 for k in (*RESULT_KINDS, *IMAGE_KINDS)}
        self.fits_failed = 0
        self.fits_no_face = 0
        self.statuses: dict[str, Status] = {}
        self.eos: EndOfStream | None = None
        self.last_result = time.monotonic()
        self.pose_latency_ms: list[float] = []
        self._lock = threading.Lock()
        self._record_images = record_images

    def subscribe(self) -> None:
        for kind in ("boxes", "fit", "pose", "expression", "eos"):
            self.svc.subscribe(self.svc.key(kind), self._on_result)
        self.svc.subscribe(status_wildcard(self.svc.stream), self._on_result)
        for kind in IMAGE_KINDS:
            self.svc.subscribe(self.svc.key(kind), self._on_image)

    def _on_image(self, sample: Any) -> None:
        kind = str(sample.key_expr).rsplit("/", 1)[-1]
        with self._lock:
            self.counts[kind] += 1
            if kind == "overlay":
                self.last_result = time.monotonic()
        if self.recorder is not None and self._record_images:
            self.recorder.write(sample.payload.to_bytes())

    def _on_result(self, sample: Any) -> None:
        payload = sample.payload.to_bytes()
        msg = self.svc.decode(payload, source=str(sample.key_expr))
        if msg is None:
            return
        if self.recorder is not None:
            self.recorder.write(payload)
        with self._lock:
            self.counts[msg.KIND] += 1
            if msg.KIND in self.indices:
                self.indices[msg.KIND].add(msg.header.frame_index)
                self.last_result = time.monotonic()
            if msg.KIND == "fit" and msg.failed:
                self.fits_failed += 1
                self.fits_no_face += len(msg.landmarks) == 0
            elif msg.KIND == "pose":
                h = msg.header
                self.pose_latency_ms.append((h.publish_time_ns - h.capture_time_ns) / 1e6)
            elif msg.KIND == "status":
                self.statuses[msg.service] = msg
            elif msg.KIND == "eos":
                self.eos = msg

    def wait_for_final_statuses(self, services: list[str], timeout: float) -> list[str]:
        """Wait until each of ``services`` has sent its last status; return those missing."""
        deadline = time.monotonic() + timeout
        while True:
            with self._lock:
                missing = [n for n in services if n not in self.statuses
                           or self.statuses[n].state not in ("stopped", "failed")]
            if not missing or time.monotonic() >= deadline:
                return missing
            time.sleep(0.02)

    def last_fit_in(self) -> bool:
        """Whether the fit of the stream's last frame has arrived."""
        if self.eos is None:
            return False
        with self._lock:
            return self.eos.total_frames == 0 or self.eos.total_frames - 1 in self.indices["fit"]

    def quiet_for(self) -> float:
        return time.monotonic() - self.last_result

    def summary(self, exclude: str = "") -> dict[str, Any]:
        """Counts, end of stream and the last status of each service, as plain data."""
        with self._lock:
            lat = sorted(self.pose_latency_ms)
            return {
                "total_frames": None if self.eos is None else self.eos.total_frames,
                "eos_reason": None if self.eos is None else self.eos.reason,
                "frames_with": {k: len(v) for k, v in self.indices.items()},
                "messages": dict(self.counts),
                "fits_failed": self.fits_failed,
                "fits_no_face": self.fits_no_face,
                "pose_latency_ms": _percentiles(lat),
                "services": {n: _status_dict(s) for n, s in sorted(self.statuses.items())
                             if n != exclude},
            }


def _percentiles(values: list[float]) -> dict[str, float | None]:
    if not values:
        return {"p50": None, "p99": None}
    import numpy as np

    p50, p99 = np.percentile(values, [50, 99])
    return {"p50": float(p50), "p99": float(p99)}


def _status_dict(s: Status) -> dict[str, Any]:
    def num(x: float) -> float | None:
        return None if math.isnan(x) else round(x, 3)

    return {"state": s.state, "frames_in": s.frames_in, "frames_out": s.frames_out,
            "dropped": s.dropped, "rejected": s.rejected, "latency_p50_ms": num(s.latency_p50_ms),
            "latency_p99_ms": num(s.latency_p99_ms), "restarts": s.restarts,
            "message": s.message}


def summary_table(summary: dict[str, Any]) -> str:
    """The summary as a few lines of text."""
    lines = [f"end of stream: {summary['total_frames']} frames ({summary['eos_reason']}); "
             f"frames with a fit {summary['frames_with']['fit']}, pose "
             f"{summary['frames_with']['pose']}, expression "
             f"{summary['frames_with']['expression']}; failed fits {summary['fits_failed']} "
             f"(no face {summary['fits_no_face']}); overlays {summary['messages']['overlay']}",
             f"{'service':<12} {'state':<9} {'in':>6} {'out':>6} {'dropped':>7} {'rejected':>8} "
             f"{'p50 ms':>7} {'p99 ms':>7} {'restarts':>8}"]
    for name, s in summary["services"].items():
        p50 = "-" if s["latency_p50_ms"] is None else f"{s['latency_p50_ms']:.1f}"
        p99 = "-" if s["latency_p99_ms"] is None else f"{s['latency_p99_ms']:.1f}"
        lines.append(f"{name:<12} {s['state']:<9} {s['frames_in']:>6} {s['frames_out']:>6} "
                     f"{s['dropped']:>7} {s['rejected']:>8} {p50:>7} {p99:>7} "
                     f"{s['restarts']:>8}")
    return "\n".join(lines)


def wait_for_end(svc: Service, sup: Supervisor, mon: StackMonitor, opts: StackOptions) -> str:
    """Watch the run until it is over; return why: ``done``, ``source failed``, ``stopped``..."""
    eos_at: float | None = None
    while not svc.wait(0.1):
        sup.check()
        if mon.eos is not None and eos_at is None:
            eos_at = time.monotonic()
            log.info("end of stream after %d frames (%s)", mon.eos.total_frames, mon.eos.reason)
        if eos_at is not None:
            waited = time.monotonic() - eos_at
            if (mon.last_fit_in() and mon.quiet_for() >= opts.drain_quiet) or (
                    waited >= opts.drain_max):
                return "done"
        elif sup.exitcode("source") is not None and (svc.wait(1.0) or mon.eos is None):
            return "source failed"  # it ended and, a second later, no end of stream came
        if sup.failed():
            return f"{', '.join(sup.failed())} could not be kept running"
    return "stopped"


class Stack:
    """The stack's processes and the launcher's view of the bus.

    Use it as a context manager: entering opens the launcher's session and
    starts every service; :meth:`wait` watches the run until it ends; leaving
    stops every process and closes the session. :attr:`supervisor` and
    :attr:`monitor` are there for the caller to inspect (or to kill a
    service in a test).

    Parameters
    ----------
    opts : StackOptions
    models : dict, optional
        Model arguments per service (see :func:`prepare_models`; computed if omitted).
    """

    def __init__(self, opts: StackOptions, models: dict[str, list[str]] | None = None) -> None:
        self.opts = opts
        self.endpoint = opts.endpoint or default_endpoint()
        self.models = prepare_models(opts) if models is None else models
        service_bus = BusOptions(opts.stream, "peer", listen=("tcp/127.0.0.1:0",),
                                 connect=(self.endpoint,))
        self.specs = service_specs(opts, service_bus, self.models)
        self.supervisor = Supervisor(self.specs, env=SERVICE_ENV)
        self.recorder = RecordWriter(opts.record) if opts.record else None
        self.service = Service(NAME, BusOptions(opts.stream, "peer", listen=(self.endpoint,)))
        self.monitor = StackMonitor(self.service, self.recorder, opts.record_images)
        self.exit_codes: dict[str, int | None] = {}
        self.outcome = "stopped"

    def __enter__(self) -> Stack:
        self.service.open()
        try:
            self.monitor.subscribe()
            self.service.ready(f"listening on {self.endpoint}")
            log.info("stack bus at %s (other programs can connect there)", self.endpoint)
            self.supervisor.start()
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def wait(self) -> str:
        """Watch the run until it ends; the outcome (see :func:`wait_for_end`)."""
        self.outcome = wait_for_end(self.service, self.supervisor, self.monitor, self.opts)
        return self.outcome

    def __exit__(self, *exc: object) -> None:
        try:
            self.exit_codes = self.supervisor.stop()
            self.monitor.wait_for_final_statuses([s.name for s in self.specs], FINAL_STATUS_WAIT)
        finally:
            self.service.close()
            if self.recorder is not None:
                self.recorder.close()

    def summary(self) -> dict[str, Any]:
        """The run's summary: the monitor's counts, outcome, exit codes and events."""
        return self.monitor.summary(exclude=NAME) | {
            "outcome": self.outcome, "exit_codes": self.exit_codes,
            "events": list(self.supervisor.events)}


def run_stack(opts: StackOptions) -> int:
    """Run the stack as ``opts`` says; the exit code (see the module notes)."""
    from services.source.capture import SourceError

    try:
        check_input(opts)
    except SourceError as exc:
        log.error("%s", exc)
        print(f"aamtrack run: error: {exc}")
        return EXIT_INPUT
    with Stack(opts) as stack:
        stack.wait()
    summary = stack.summary()
    print(summary_table(summary))
    if opts.summary:
        Path(opts.summary).write_text(json.dumps(summary, indent=2))
    return exit_code(stack.outcome, summary)


def exit_code(outcome: str, summary: dict[str, Any]) -> int:
    """0 for a run that reached its end, else the reason's code, with a message."""
    reason = summary.get("eos_reason") or ""
    if outcome == "done" and not reason.startswith("error"):
        return EXIT_OK
    if outcome == "stopped":
        print("aamtrack run: interrupted")
        return EXIT_INTERRUPTED
    why = reason.removeprefix("error: ") if reason.startswith("error") else outcome
    print(f"aamtrack run: error: {why}")
    return EXIT_FAILED
