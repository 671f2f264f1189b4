"""Tools beside a running stack: ``aamtrack echo`` and ``aamtrack record``.

- ``aamtrack echo KEYEXPR``: print each message on a key expression, one line each.
- ``aamtrack record --out FILE``: write every result message of a stream to a
  file (:mod:`services.stack.recorder`).

Both connect to the stream's socket in the user's private folder (where
``aamtrack run`` listens by default, :mod:`services.bus.runtime`) unless told
otherwise, publish nothing on the stack's stream, and give up with exit status 1
when no stack answers within ``--timeout`` seconds.

Neither holds a secret, and both keep only the run's messages: they fetch the run's public
keys from its launcher (:mod:`services.bus.run_keys`; ``--trust FP`` names the launcher key
aamtrack run printed) and check every message against them; what fails is counted, said at
the end, and neither printed nor recorded. ``--unverified`` takes every well-formed
message of a stack without keys, and says so.
"""

from __future__ import annotations

import argparse
import math
import sys
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from proto.keys import TOPICS, status_wildcard, topic_key
from services.bus.connection import BusOptions
from services.bus.options import OptionError, add_options, options_from
from services.cli.commands import add_command
from services.stack.drain import DRAIN_MAX, DRAIN_QUIET

if TYPE_CHECKING:  # the bus and the codec are imported when a command runs, not for its help
    from proto import Message
    from services.bus.session import Service

DEFAULT_TIMEOUT = 10.0
"""Seconds to wait for a stack before giving up."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``echo`` and ``record``."""
    p = add_command(subparsers, "echo",
                              description="Subscribe to KEYEXPR and print one line per message.")
    p.add_argument("keyexpr", help="e.g. aamtrack/cam0/** or aamtrack/*/pose")
    p.add_argument("--count", type=int, default=0, help="stop after N messages")
    _common(p)
    p.set_defaults(func=cmd_echo)
    p = add_command(subparsers, "record",
                              description="Write every fit, pose, expression, boxes, status "
                              "and end-of-stream message to FILE (services.stack.recorder).")
    p.add_argument("--out", required=True, help="recording file")
    p.add_argument("--frames", action="store_true", help="record frames too")
    p.add_argument("--overlays", action="store_true", help="record overlays too")
    p.add_argument("--until-eos", action="store_true",
                   help="stop after the stream's end of stream, once the last frame's fit has "
                   f"come and nothing came for {DRAIN_QUIET:g} s (at most --drain-max s)")
    p.add_argument("--drain-max", type=float, default=DRAIN_MAX, metavar="S",
                   help="with --until-eos: the longest wait for results after the end of "
                   f"stream (default {DRAIN_MAX:g})")
    _common(p)
    p.set_defaults(func=cmd_record)


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT, metavar="S",
                   help="give up (exit 1) when no stack answers within S seconds "
                   f"(default {DEFAULT_TIMEOUT:g})")
    p.add_argument("--duration", type=float, default=0.0, metavar="S",
                   help="stop after S seconds (default: until stopped)")
    p.add_argument("--unverified", action="store_true",
                   help="take every well-formed message, checking no signature (a stack "
                   "without keys); said in the output")
    add_options(p.add_argument_group("bus"), BusOptions)


def _client(args: argparse.Namespace) -> Service | None:
    """The session of ``echo`` or ``record`` (not announced on the stack's stream): by
    default it connects where ``run`` listens; None, with a message, for bad options."""
    from services.bus.process import init_process
    from services.bus.runtime import stream_endpoint
    from services.bus.session import Service

    try:
        bus = options_from(BusOptions, args)
        if not bus.listen and not bus.connect:
            bus = bus.replace(connect=(stream_endpoint(bus.stream),))
    except OptionError as exc:
        print(f"aamtrack {args.command}: error: {exc}", file=sys.stderr)
        return None
    init_process(args.command, args.verbose)
    return Service(args.command, bus.replace(trust=""), announce=False)


def _trusted(svc: Service, args: argparse.Namespace) -> str | None:
    """Fetch the run's public keys (unless ``--unverified``): what the output is checked
    against, in words; None, with a message, when no run can be trusted."""
    if args.unverified:
        return "UNVERIFIED: no signature checked (--unverified)"
    if svc.keyring:  # --keys: a deployment's keys file, read for its public keys
        return f"verified against the public keys of {svc.bus.keys}"
    try:
        keys = svc.trust_run(args.trust, args.timeout)
    except OptionError as exc:
        print(f"aamtrack {args.command}: error: {exc}", file=sys.stderr)
        return None
    anchor = ("trusted by --trust" if args.trust else
              f"not anchored: the only launcher that answered; give --trust {keys.fingerprint}"
              " to pin it")
    return (f"verified against run {keys.run_id or '?'}, launcher key {keys.fingerprint} "
            f"({anchor})")


def _screened(svc: Service, sample: Any, replays: Any) -> tuple[Message | None, bytes]:
    """The message of a sample if it is the run's (checked when keys are held), and its
    bytes; None when it is not a message or not the run's (counted)."""
    from proto.keys import parse_key
    from proto.limits import ProtoError

    key, payload = str(sample.key_expr), sample.payload.to_bytes()
    try:
        topic = parse_key(key)[1]
    except ProtoError:
        topic = None
    if topic in ("alive", "detect", "keys"):
        return None, payload
    if not svc.keyring:  # --unverified: any well-formed message
        return svc.decode(payload, topic, key), payload
    return svc.screen.check(payload, key, topic, replays), payload


def _said_ignored(svc: Service) -> str:
    s = svc.stats
    parts = [f"{n} {why}" for why, n in sorted(s.ignored_by.items())]
    parts += [f"{s.rejected} malformed"] if s.rejected else []
    return f"; left out (not the run's): {', '.join(parts)}" if parts else ""


def _wait_for_peer(svc: Service, timeout: float) -> bool:
    """Whether a peer (the stack) is connected within ``timeout`` seconds."""
    deadline = time.monotonic() + timeout
    while not svc.peers():
        if time.monotonic() >= deadline or svc.wait(0.05):
            return False
    return True


def _found(svc: Service, args: argparse.Namespace) -> bool:
    """Whether a stack is connected within ``--timeout`` (else said)."""
    if not _wait_for_peer(svc, args.timeout):
        where = ", ".join(svc.bus.connect or svc.bus.listen)
        print(f"aamtrack {args.command}: error: no aamtrack stack answered at {where} within "
              f"{args.timeout:g} s", file=sys.stderr)
        return False
    return True


def _run(svc: Service, args: argparse.Namespace, done: Callable[[], bool]) -> int:
    """Run until ``done()``, stopped or ``--duration``."""
    deadline = time.monotonic() + args.duration if args.duration > 0 else math.inf
    while not done() and not svc.wait(0.05) and time.monotonic() < deadline:
        pass
    return 0


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
        found = msg.appearance
        body = (f"{len(msg.landmarks)} points, "
                + ("no appearance" if found is None else
                   f"error {found.texture_error:.4g}, {found.iterations} it, "
                   f"{int(found.occluded.sum())} occluded")
                + f", warp {msg.warp_path}"
                + (f", FAILED: {msg.failure_reason}" if msg.failed else ""))
    elif kind == "pose":
        t = msg.translation_mm
        body = (f"roll {msg.roll_deg:.1f} pitch {msg.pitch_deg:.1f} yaw {msg.yaw_deg:.1f} deg, "
                f"T [{t[0]:.0f} {t[1]:.0f} {t[2]:.0f}] mm"
                + ("" if msg.reliable else ", unreliable"))
    elif kind == "expression":
        best = float(max(msg.scores)) if len(msg.scores) else math.nan
        body = (f"{msg.label} ({best:.2f})" + (", smoothed" if msg.smoothed else "")
                if msg.label else f"no label: {msg.reason}")
    elif kind == "status":
        body = (f"{msg.service} {msg.state} in {msg.frames_in} out {msg.frames_out} "
                f"dropped {msg.dropped} rejected {msg.rejected} lost {msg.lost} ignored "
                f"{msg.ignored} p50 "
                f"{_number(msg.latency_p50_ms)} ms p99 {_number(msg.latency_p99_ms)} ms"
                + (f" restarts {msg.restarts}" if msg.restarts else "")
                + (f" | {msg.message}" if msg.message else ""))
    else:
        body = f"{msg.total_frames} frames, {msg.reason}"
    return f"{head}: {body}"


def cmd_echo(args: argparse.Namespace) -> int:
    """``aamtrack echo KEYEXPR``."""
    from services.bus.trust import Replays

    client = _client(args)
    if client is None:
        return 2
    done, lock, seen, replays = threading.Event(), threading.Lock(), [0], Replays()
    with client as svc:
        if not _found(svc, args) or (checked := _trusted(svc, args)) is None:
            return 1
        print(f"aamtrack echo: {checked}", file=sys.stderr, flush=True)

        def on_sample(sample: Any) -> None:
            msg, _ = _screened(svc, sample, replays)
            if msg is None:
                return
            with lock:
                if done.is_set():
                    return
                print(describe(msg), flush=True)
                seen[0] += 1
                if args.count and seen[0] >= args.count:
                    done.set()

        svc.subscribe(args.keyexpr, on_sample)
        svc.ready()
        code = _run(svc, args, done.is_set)
    print(f"aamtrack echo: {seen[0]} messages, {checked}{_said_ignored(svc)}", file=sys.stderr)
    return code


def record_keys(stream: str, frames: bool, overlays: bool) -> list[str]:
    """Keys a recording of ``stream`` subscribes to."""
    from services.stack.recorder import IMAGE_KINDS, RESULT_KINDS

    kinds = [k for k in RESULT_KINDS if k in TOPICS]
    kinds += [k for k, on in zip(IMAGE_KINDS, (frames, overlays), strict=True) if on]
    return [topic_key(stream, k) for k in kinds] + [status_wildcard(stream)]


def cmd_record(args: argparse.Namespace) -> int:
    """``aamtrack record --out FILE``."""
    from services.bus.trust import Replays
    from services.stack.drain import EndOfRun
    from services.stack.preflight import PreflightError, check_output
    from services.stack.recorder import RecordWriter

    try:
        check_output("--out", args.out)
    except PreflightError as exc:
        print(f"aamtrack record: error: {exc}", file=sys.stderr)
        return 2
    client = _client(args)
    if client is None:
        return 2
    end, replays = EndOfRun(drain_max=args.drain_max), Replays()
    with client as svc:
        if not _found(svc, args) or (checked := _trusted(svc, args)) is None:
            return 1
        keys = b"" if svc.run_keys is None else svc.run_keys.document
        with RecordWriter(args.out, keys) as writer:
            def on_sample(sample: Any) -> None:
                msg, payload = _screened(svc, sample, replays)
                if msg is None:
                    return
                writer.write(payload)
                svc.stats.count_in(msg.header)
                end.saw(msg)

            for key in record_keys(svc.stream, args.frames, args.overlays):
                svc.subscribe(key, on_sample)
            svc.ready(f"recording to {args.out}")
            code = _run(svc, args, end.over if args.until_eos else lambda: False)
    print(f"recorded {writer.count} messages to {args.out}, {checked}{_said_ignored(svc)}",
          file=sys.stderr)
    return code
