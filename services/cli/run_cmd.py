"""Commands that run the stack or talk to it: ``run``, ``service``, ``echo``, ``record``.

- ``aamtrack run --video FILE [--rrd out.rrd]``: the whole stack on one host
  (:mod:`services.stack.launcher`).
- ``aamtrack service NAME [ARGS...]``: one service alone, e.g. on another
  machine (``aamtrack service fitter --connect tcp/10.0.0.2:7447``).
- ``aamtrack echo KEYEXPR``: print each message on a key expression, one line each.
- ``aamtrack record --out FILE``: write every result message of a stream to a
  file (:mod:`services.stack.recorder`).
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import logging
import math
import sys
import threading
import time
from typing import Any

from aamcore.fitting.algorithm import ALGORITHMS
from proto import Message
from proto.keys import TOPICS, status_wildcard, topic_key
from services.bus.runtime import BusOptions, Service, add_bus_arguments, init_process
from services.source.pacing import PACES
from services.stack.recorder import IMAGE_KINDS, RESULT_KINDS, RecordWriter
from services.stack.supervisor import SERVICE_MODULES

log = logging.getLogger("aamtrack.cli")


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``run``, ``service``, ``echo`` and ``record``."""
    _register_run(subparsers)
    p = subparsers.add_parser("service", help="run one service of the stack alone",
                              description="Run one service; its arguments follow its name "
                              "(aamtrack service fitter --help).")
    p.add_argument("name", choices=sorted(SERVICE_MODULES), help="the service")
    p.add_argument("args", nargs=argparse.REMAINDER, help="the service's own arguments")
    p.set_defaults(func=cmd_service)
    _register_echo(subparsers)
    _register_record(subparsers)


def _register_run(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("run", help="run the tracking stack on a video, camera or stream",
                              description="Start every service as its own process, run until "
                              "the end of the input, stop them all and print a summary.")
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--video", help="video file")
    src.add_argument("--camera", type=int, help="camera index")
    src.add_argument("--url", help="stream URL (rtsp://, http://, ...)")
    p.add_argument("--stream", default="cam0", help="stream id (default cam0)")
    p.add_argument("--pace", choices=PACES, default="realtime",
                   help="realtime: the file's frame rate; fast: as fast as the stack goes")
    p.add_argument("--loop", type=int, default=1, metavar="N", help="play the file N times")
    p.add_argument("--jpeg", type=int, default=0, metavar="Q",
                   help="send frames as JPEG of quality Q instead of raw")
    p.add_argument("--max-frames", type=int, default=0, help="stop after N frames")
    p.add_argument("--warp", choices=("auto", "gpu", "cpu"), default="auto",
                   help="fitter warp path (auto: GPU only on a hardware GL renderer)")
    p.add_argument("--algorithm", choices=ALGORITHMS,
                   help="fitting algorithm (default: the fitter service's)")
    p.add_argument("--model", help="AAM model file (default: cached, trained on first use)")
    p.add_argument("--model-limit", type=int, default=0,
                   help="train the default model on the first N images (small, for tests)")
    p.add_argument("--model-images", type=int, default=30,
                   help="images for the default model's update matrix")
    p.add_argument("--classifier", help="expression classifier file (default: cached)")
    cam = p.add_mutually_exclusive_group()
    cam.add_argument("--fov", type=float, default=60.0, help="assumed horizontal FOV, degrees")
    cam.add_argument("--calibration", help="camera calibration file")
    p.add_argument("--no-ar", action="store_true", help="do not start the glasses renderer")
    p.add_argument("--rrd", help="write a Rerun recording to this file")
    p.add_argument("--rerun", type=int, metavar="PORT", dest="rerun_port",
                   help="serve a live Rerun view on 127.0.0.1:PORT")
    p.add_argument("--endpoint", metavar="ENDPOINT",
                   help="zenoh endpoint the stack listens on, for other programs to connect "
                   "to (default tcp/127.0.0.1:7447 if free, else a free loopback port)")
    p.add_argument("--record", metavar="FILE", help="record every result message to FILE")
    p.add_argument("--record-images", action="store_true",
                   help="with --record: frames and overlays too")
    p.add_argument("--summary", metavar="FILE", help="write the run's summary as JSON")
    p.add_argument("--no-restart", action="store_true", help="do not restart dead services")
    p.add_argument("--drain-max", type=float, default=20.0,
                   help="seconds to wait for results after end of stream")
    p.add_argument("--set", action="append", default=[], metavar="SERVICE:ARG",
                   help="extra argument for one service, e.g. fitter:--detect-timeout=2")
    p.set_defaults(func=cmd_run)


def _register_echo(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("echo", help="print the messages on a key expression",
                              description="Subscribe to KEYEXPR and print one line per message.")
    p.add_argument("keyexpr", help="e.g. aamtrack/cam0/** or aamtrack/*/pose")
    p.add_argument("--count", type=int, default=0, help="stop after N messages")
    p.add_argument("--timeout", type=float, default=0.0, help="stop after S seconds")
    add_bus_arguments(p, verbose=False)
    p.set_defaults(func=cmd_echo)


def _register_record(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("record", help="record a stream's result messages to a file",
                              description="Write every fit, pose, expression, boxes, status "
                              "and end-of-stream message to FILE (services.stack.recorder).")
    p.add_argument("--out", required=True, help="recording file")
    p.add_argument("--frames", action="store_true", help="record frames too")
    p.add_argument("--overlays", action="store_true", help="record overlays too")
    p.add_argument("--until-eos", action="store_true",
                   help="stop 2 s after the stream's end of stream")
    p.add_argument("--timeout", type=float, default=0.0, help="stop after S seconds")
    add_bus_arguments(p, verbose=False)
    p.set_defaults(func=cmd_record)


def _extra_args(items: list[str]) -> dict[str, list[str]]:
    extra: dict[str, list[str]] = {}
    for item in items:
        name, sep, arg = item.partition(":")
        if not sep or name not in SERVICE_MODULES or not arg:
            raise ValueError(f"--set {item!r}: expected SERVICE:ARG with SERVICE one of "
                             f"{sorted(SERVICE_MODULES)}")
        extra.setdefault(name, []).append(arg)
    return extra


def cmd_run(args: argparse.Namespace) -> int:
    """``aamtrack run``."""
    from services.stack.launcher import StackOptions, run_stack

    opts = StackOptions(
        video=args.video, camera=args.camera, url=args.url, stream=args.stream, pace=args.pace,
        loop=args.loop, jpeg=args.jpeg, max_frames=args.max_frames, warp=args.warp,
        algorithm=args.algorithm,
        model=args.model, model_limit=args.model_limit, model_images=args.model_images,
        classifier=args.classifier, fov=args.fov, calibration=args.calibration,
        ar=not args.no_ar, rrd=args.rrd, rerun_port=args.rerun_port, endpoint=args.endpoint,
        record=args.record,
        record_images=args.record_images, summary=args.summary, restart=not args.no_restart,
        drain_max=args.drain_max, verbose=args.verbose, extra=_extra_args(args.set),
    )
    return run_stack(opts)


def cmd_service(args: argparse.Namespace) -> int:
    """``aamtrack service NAME ARGS...``."""
    argv = list(args.args)
    if argv[:1] == ["--"]:
        argv = argv[1:]
    if args.verbose and "--verbose" not in argv:
        argv.append("--verbose")
    return int(importlib.import_module(SERVICE_MODULES[args.name]).main(argv) or 0)


def _number(x: float) -> str:
    return "nan" if math.isnan(x) else f"{x:.1f}"


def describe(msg: Message) -> str:
    """One line about a message: kind, frame, producer, latency and the body's gist."""
    h = msg.header
    head = (f"{msg.KIND:<10} {h.stream_id} #{h.frame_index} from {h.producer} "
            f"+{(h.publish_time_ns - h.capture_time_ns) / 1e6:.1f} ms")
    kind = msg.KIND
    if kind in ("frame", "overlay"):
        body = f"{msg.width}x{msg.height} {msg.encoding}"
    elif kind == "boxes":
        body = f"{len(msg.boxes)} boxes {msg.boxes.round(1).tolist()}"
    elif kind == "fit":
        body = (f"{len(msg.landmarks)} points, error {msg.texture_error:.4g}, "
                f"{msg.iterations} it, warp {msg.warp_path}"
                + (f", FAILED: {msg.failure_reason}" if msg.failed else ""))
    elif kind == "pose":
        t = msg.translation_mm
        body = (f"roll {msg.roll_deg:.1f} pitch {msg.pitch_deg:.1f} yaw {msg.yaw_deg:.1f} deg, "
                f"T [{t[0]:.0f} {t[1]:.0f} {t[2]:.0f}] mm"
                + ("" if msg.reliable else ", unreliable"))
    elif kind == "expression":
        best = float(max(msg.scores)) if len(msg.scores) else math.nan
        body = f"{msg.label} ({best:.2f})" + (", smoothed" if msg.smoothed else "")
    elif kind == "status":
        body = (f"{msg.service} {msg.state} in {msg.frames_in} out {msg.frames_out} "
                f"dropped {msg.dropped} rejected {msg.rejected} p50 "
                f"{_number(msg.latency_p50_ms)} ms p99 {_number(msg.latency_p99_ms)} ms"
                + (f" restarts {msg.restarts}" if msg.restarts else "")
                + (f" | {msg.message}" if msg.message else ""))
    else:
        body = f"{msg.total_frames} frames, {msg.reason}"
    return f"{head}: {body}"


def _client_bus(args: argparse.Namespace) -> BusOptions:
    """The bus options of ``echo`` and ``record``: by default, connect where ``run`` listens."""
    from services.stack.launcher import DEFAULT_ENDPOINT

    bus = BusOptions.from_args(args)
    if not bus.listen and not bus.connect:
        bus = dataclasses.replace(bus, connect=(DEFAULT_ENDPOINT,))
    return bus


def _run_for(svc: Service, done: threading.Event, timeout: float) -> None:
    deadline = time.monotonic() + timeout if timeout > 0 else math.inf
    while not done.is_set() and not svc.wait(0.05):
        if time.monotonic() >= deadline:
            break


def cmd_echo(args: argparse.Namespace) -> int:
    """``aamtrack echo KEYEXPR``."""
    init_process("echo", args.verbose)
    done = threading.Event()
    lock = threading.Lock()
    seen = [0]
    with Service("echo", _client_bus(args)) as svc:
        def on_sample(sample: Any) -> None:
            msg = svc.decode(sample.payload.to_bytes(), source=str(sample.key_expr))
            line = (describe(msg) if msg is not None
                    else f"{'rejected':<10} {sample.key_expr}: see the log for the reason")
            with lock:
                if done.is_set():
                    return
                print(line, flush=True)
                seen[0] += 1
                if args.count and seen[0] >= args.count:
                    done.set()

        svc.subscribe(args.keyexpr, on_sample)
        svc.ready()
        _run_for(svc, done, args.timeout)
    return 0


def record_keys(stream: str, frames: bool, overlays: bool) -> list[str]:
    """Keys a recording of ``stream`` subscribes to."""
    kinds = [k for k in RESULT_KINDS if k in TOPICS]
    kinds += [k for k, on in zip(IMAGE_KINDS, (frames, overlays), strict=True) if on]
    return [topic_key(stream, k) for k in kinds] + [status_wildcard(stream)]


def cmd_record(args: argparse.Namespace) -> int:
    """``aamtrack record --out FILE``."""
    init_process("record", args.verbose)
    bus = _client_bus(args)
    with RecordWriter(args.out) as writer, Service("record", bus) as svc:
        eos_at: list[float] = []

        def on_sample(sample: Any) -> None:
            payload = sample.payload.to_bytes()
            msg = svc.decode(payload, source=str(sample.key_expr))
            if msg is None:
                return
            writer.write(payload)
            svc.stats.count_in(msg.header)
            if msg.KIND == "eos" and args.until_eos and not eos_at:
                eos_at.append(time.monotonic())

        for key in record_keys(bus.stream, args.frames, args.overlays):
            svc.subscribe(key, on_sample)
        svc.ready(f"recording to {args.out}")
        deadline = time.monotonic() + args.timeout if args.timeout > 0 else math.inf
        while not svc.wait(0.1) and time.monotonic() < deadline:
            if eos_at and time.monotonic() - eos_at[0] >= 2.0:
                break
    print(f"recorded {writer.count} messages to {args.out}", file=sys.stderr)
    return 0
