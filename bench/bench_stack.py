"""Bench: the whole service stack end to end on ``single_face.mp4``.

1. **Throughput**: the video looped ``--loops`` times at the fastest pacing
   (the source keeps at most two frames ahead of the fitter's answers), every
   service in its own process (detector, fitter, pose, expression, glasses
   renderer, source; ``--rerun`` adds the Rerun logger writing an ``.rrd``).
   Frames per second from the first frame's capture to the last fit, and
   whether every frame got a fit, every fit with landmarks a pose and every
   good fit an expression (from the frame where the face's reference is
   learned). Target: >= 140 frames/s (on two cores, the default options).
2. **Latency** at real-time pacing (the file's 30 frames/s, looped
   ``--latency-loops`` times): capture to published pose, p50 and p99 over
   every pose. Target: p99 <= 25 ms.
3. **Per stage**, for the throughput run: processing time per message (p50
   and p99 of each service's own status), CPU seconds per frame of each
   process (from ``/proc``) and its share of all the stack's CPU time.
4. **Warps**: the fitter's texture warps per frame and milliseconds per warp on
   each path (its status counts them), and the fits that carry the AAM's
   appearance, so that ``--warp gpu`` and ``--warp cpu`` compare two paths.

Run: ``python -m bench stack [--loops 8] [--latency-loops 3] [--warp gpu|cpu]
[--small-model] [--no-ar] [--rerun]``. It prints the tables; the tool, the targets met or missed.
"""

from __future__ import annotations

import contextlib
import os
import re
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aamcore.config import data_root
from aamcore.expression.spec import STREAM_REFERENCE
from bench import options
from bench.targets import Target
from services.stack.launcher import Stack, prepared
from services.stack.options import StackOptions, parse_run_args
from services.stack.recorder import load_messages

THROUGHPUT = Target("throughput at the fastest pacing", ">=", 140.0, "frames/s")
ANSWERED = Target("every frame answered at the fastest pacing", "==", True)
P99 = Target("capture to pose p99, real-time pacing", "<=", 25.0, "ms")
TARGETS = (THROUGHPUT, ANSWERED, P99)
CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float:
    """User + system CPU seconds of a process so far."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS


@dataclass
class RunResult:
    opts: StackOptions
    summary: dict
    messages: list
    cpu: dict[str, float]
    wall_s: float


def run(opts: StackOptions, rec: Path) -> RunResult:
    """Run a stack and measure the CPU of each process until end of stream."""
    opts = prepared(opts)
    with Stack(opts) as stack:
        pids = {}
        deadline = time.monotonic() + 120
        while len(pids) < len(stack.specs) and time.monotonic() < deadline:
            pids = {s.name: stack.supervisor.pid(s.name) for s in stack.specs}
            pids = {k: v for k, v in pids.items() if v is not None}
            time.sleep(0.05)
        start_cpu = {k: cpu_seconds(v) for k, v in pids.items()}
        last_cpu = dict(start_cpu)
        done = threading.Event()

        def sample() -> None:  # the source exits at the end: keep its last reading
            while not done.wait(0.05):
                for name, pid in pids.items():
                    with contextlib.suppress(OSError, IndexError, ValueError):
                        last_cpu[name] = cpu_seconds(pid)

        sampler = threading.Thread(target=sample, daemon=True)
        sampler.start()
        start_self = time.process_time()
        started = time.monotonic()
        outcome = stack.wait()
        wall = time.monotonic() - started
        done.set()
        sampler.join()
        cpu = {name: last_cpu[name] - start_cpu[name] for name in pids}
        cpu["launcher"] = time.process_time() - start_self
    if outcome != "done":
        sys.exit(f"the stack did not finish: {outcome}")
    return RunResult(opts, stack.summary(), load_messages(rec), cpu, wall)


def by_kind(messages: list, kind: str) -> dict[int, object]:
    return {m.header.frame_index: m for m in messages if kind == m.KIND}


def throughput(result: RunResult) -> tuple[float, bool, str]:
    """Frames per second, whether every frame got its results, and a note."""
    fits = by_kind(result.messages, "fit")
    poses = by_kind(result.messages, "pose")
    exprs = by_kind(result.messages, "expression")
    total = result.summary["total_frames"]
    with_face = {i for i, f in fits.items() if len(f.landmarks)}
    # No expression while the expression service learns the face's reference (one run: the
    # loops number their frames on).
    warm_up = (STREAM_REFERENCE["min_count"] - 1) * STREAM_REFERENCE["stride"]
    good = {i for i, f in fits.items() if not f.failed and i >= warm_up}
    complete = (len(fits) == total and with_face <= set(poses) and good <= set(exprs))
    first = min(m.header.capture_time_ns for m in fits.values())
    last = max(m.header.publish_time_ns for m in fits.values())
    fps = (total - 1) / ((last - first) / 1e9)
    note = (f"{total} frames: fits {len(fits)}, poses {len(poses)} (fits with a face "
            f"{len(with_face)}), expressions {len(exprs)} (good fits from frame {warm_up} "
            f"{len(good)})")
    return fps, complete, note


WARPS = re.compile(r"warps gpu (\d+)(?: \(([\d.]+) ms\))?, cpu (\d+)(?: \(([\d.]+) ms\))?")


def warp_line(result: RunResult) -> str:
    """The fitter's warps per frame and time per warp by path, from its last status."""
    message = result.summary["services"].get("fitter", {}).get("message", "")
    found = WARPS.search(message)
    fits = by_kind(result.messages, "fit")
    with_c = sum(f.appearance is not None for f in fits.values())
    good = sum(not f.failed for f in fits.values())
    paths = sorted({f.warp_path for f in fits.values()})
    if found is None:
        return f"fitter warps: not reported ({message!r})"
    gpu, gpu_ms, cpu, cpu_ms = found.groups()
    total = result.summary["total_frames"]
    per = (int(gpu) + int(cpu)) / max(total, 1)
    times = ", ".join(f"{p} {ms} ms per warp" for p, ms in (("gpu", gpu_ms), ("cpu", cpu_ms))
                      if ms)
    return (f"fitter warps: {per:.2f} per frame (gpu {gpu}, cpu {cpu}; {times or 'none'}); "
            f"fits with the appearance {with_c} of {good} good; warp paths {paths}")


def stage_table(result: RunResult) -> str:
    total = result.summary["total_frames"]
    cpu_total = sum(v for v in result.cpu.values() if np.isfinite(v))
    lines = [f"{'stage':<12} {'in':>6} {'out':>6} {'drop':>5} {'p50 ms':>7} {'p99 ms':>7} "
             f"{'CPU ms/frame':>12} {'CPU share':>9}"]
    for name, cpu in sorted(result.cpu.items(), key=lambda kv: -np.nan_to_num(kv[1])):
        s = result.summary["services"].get(name, {})
        p50, p99 = s.get("latency_p50_ms"), s.get("latency_p99_ms")
        lines.append(
            f"{name:<12} {s.get('frames_in', '-'):>6} {s.get('frames_out', '-'):>6} "
            f"{s.get('dropped', '-'):>5} {'-' if p50 is None else f'{p50:.2f}':>7} "
            f"{'-' if p99 is None else f'{p99:.2f}':>7} {1000 * cpu / total:>12.2f} "
            f"{cpu / cpu_total if np.isfinite(cpu) else float('nan'):>9.1%}")
    lines.append(f"CPU in all: {cpu_total:.1f} s over {result.wall_s:.1f} s wall "
                 f"({cpu_total / result.wall_s / os.cpu_count():.0%} of {os.cpu_count()} cores)")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__, model=True)
    parser.add_argument("--loops", type=int, default=8, help="plays of the video, throughput")
    parser.add_argument("--latency-loops", type=int, default=3, help="plays, latency run")
    parser.add_argument("--warp", choices=("auto", "gpu", "cpu"), default="auto")
    parser.add_argument("--small-model", action="store_true",
                        help="the small test model instead of the default one")
    parser.add_argument("--no-ar", action="store_true", help="leave the glasses renderer out")
    parser.add_argument("--rerun", action="store_true", help="add the Rerun logger (.rrd)")
    parser.add_argument("--algorithm", help="the fitter's algorithm (default: the stack's)")
    args = options.parse(parser, argv)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    video = data_root() / "videos" / "single_face.mp4"
    with tempfile.TemporaryDirectory() as tmp:
        common = ["--video", str(video), "--warp", args.warp,
                  *(["--no-ar"] if args.no_ar else []),
                  *(["--algorithm", args.algorithm] if args.algorithm else []),
                  *(["--model-limit", "300", "--model-images", "10"] if args.small_model else []),
                  *(["--model", str(args.model)] if args.model else [])]
        rec = Path(tmp) / "fast.rec"
        rrd = ["--rrd", str(Path(tmp) / "run.rrd")] if args.rerun else []
        fast = run(parse_run_args([*common, "--pace", "fast", "--loop", str(args.loops),
                                   "--record", str(rec), *rrd]), rec)
        rec = Path(tmp) / "realtime.rec"
        slow = run(parse_run_args([*common, "--pace", "realtime", "--loop",
                                   str(args.latency_loops), "--record", str(rec)]), rec)
    fps, complete, note = throughput(fast)
    lat = np.array([(m.header.publish_time_ns - m.header.capture_time_ns) / 1e6
                    for m in slow.messages if m.KIND == "pose"])
    p50, p99 = np.percentile(lat, [50, 99])
    fitter_drop = slow.summary["services"]["fitter"]["dropped"]
    algorithm = fast.opts.services["fitter"].algorithm
    print(f"stack: detector, fitter ({algorithm}, {args.warp} warp), pose, expression"
          f"{'' if args.no_ar else ', ar'}{', rerun' if args.rerun else ''}, source; "
          f"{os.cpu_count()} cores; model "
          f"{args.model or ('small' if args.small_model else 'default (lfpw,helen,afw)')}")
    print(f"\nthroughput, fastest pacing, {args.loops} plays: {fps:.1f} frames/s; {note}")
    print(f"latency, real-time pacing, {args.latency_loops} plays: capture to pose p50 "
          f"{p50:.1f} ms, p99 {p99:.1f} ms over {len(lat)} poses "
          f"({fitter_drop} frames dropped by the fitter)")
    print(warp_line(fast))
    print("\nper stage, throughput run:")
    print(stage_table(fast))
    ok = THROUGHPUT.check(fps) & ANSWERED.check(bool(complete)) & P99.check(float(p99))
    return 0 if ok else 1

