"""Bench: the service stack against the library, in one run, on the same video.

The video is ``single_face.mp4`` played forward then backward (no cut at the joins), once
for the short clip and ``--plays`` times for the long one, written once to a temporary file
that both sides decode.

1. **Marginal CPU a frame**: CPU seconds of every process and thread (the stack: each
   service process and the launcher; the library: the process running
   ``FaceTracker.process_video``, video decode included on both sides), long clip less
   short clip, over the frames between: start-up, warm-up and the drain at the end cancel.
   The stack at real-time pacing (what a camera gives it). Target: the stack <= 1.5 x the
   library.
2. **Per service**: CPU ms a frame of each process of the long real-time run and of the
   fast run.
3. **Fast pacing** (``--pace fast``, the long clip): frames a second from the first
   frame's capture to the last fit; overlays drawn per reliable pose (a pose the renderer
   is given and draws) and per pose; capture-to-pose p50 and p99. Targets: >= 180 frames/s,
   overlays for >= 95 % of the poses, p99 <= 40 ms.
4. **Real-time pacing** (the long clip at 30 frames/s): every frame answered (a fit per
   frame, a pose per fit with a face), capture-to-pose p50 and p99. Target: p99 <= 10 ms.

The load of the machine (``os.getloadavg``) is printed before and after: the figures are
CPU time (what the machine's other work changes least) and wall time (what it changes most).

Run: ``python -m bench stack-vs-library [--plays 3] [--warp cpu]``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from aamcore.config import data_root
from bench import options
from bench.bench_stack import RunResult, run
from bench.targets import Target
from services.stack.options import parse_run_args

RATIO = Target("marginal CPU a frame, stack at real-time pacing / library", "<=", 1.5, "x")
FAST_FPS = Target("--pace fast: frames a second", ">=", 180.0, "frames/s")
OVERLAYS = Target("--pace fast: overlays per reliable pose", ">=", 95.0, "%")
FAST_P99 = Target("--pace fast: capture to pose p99", "<=", 40.0, "ms")
REALTIME_P99 = Target("real-time pacing: capture to pose p99", "<=", 10.0, "ms")
REALTIME_ANSWERED = Target("real-time pacing: every frame answered", "==", True)
TARGETS = (RATIO, FAST_FPS, OVERLAYS, FAST_P99, REALTIME_P99, REALTIME_ANSWERED)

LIBRARY = """
import json, sys, time
from aamcore.tracker import FaceTracker
with FaceTracker() as tracker:
    started = time.process_time()
    frames = sum(1 for _ in tracker.process_video(sys.argv[1]))
    print(json.dumps({"frames": frames, "cpu_s": time.process_time() - started}))
"""
"""The library on a clip in a process of its own: CPU of all its threads, model load apart."""


def ping_pong(source: Path, out: Path, plays: int) -> int:
    """Write ``source`` forward then backward ``plays`` times to ``out``; its frame count."""
    cap = cv2.VideoCapture(str(source))
    frames = []
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        frames.append(frame)
    fps = cap.get(cv2.CAP_PROP_FPS) or 30.0
    cap.release()
    h, w = frames[0].shape[:2]
    writer = cv2.VideoWriter(str(out), cv2.VideoWriter_fourcc(*"mp4v"), fps, (w, h))
    sequence = (frames + frames[::-1]) * plays
    for frame in sequence:
        writer.write(frame)
    writer.release()
    return len(sequence)


def library_cpu(clip: Path) -> tuple[int, float]:
    """Frames tracked and CPU seconds of the library on ``clip``."""
    done = subprocess.run([sys.executable, "-c", LIBRARY, str(clip)], capture_output=True,
                          text=True, check=True, env=os.environ | {"OMP_NUM_THREADS": "1"})
    got = json.loads(done.stdout.strip().splitlines()[-1])
    return int(got["frames"]), float(got["cpu_s"])


def stack_run(clip: Path, pace: str, warp: str, tmp: Path) -> RunResult:
    rec = tmp / f"{clip.stem}-{pace}.rec"
    return run(parse_run_args(["--video", str(clip), "--pace", pace, "--warp", warp,
                               "--record", str(rec)]), rec)


@dataclass
class Pacing:
    fps: float
    p50: float
    p99: float
    answered: bool
    overlays: int
    poses: int
    reliable: int


def pacing(result: RunResult) -> Pacing:
    """Frames a second, capture-to-pose percentiles, completeness, overlays of a run."""
    msgs = result.messages
    fits = [m for m in msgs if m.KIND == "fit"]
    poses = [m for m in msgs if m.KIND == "pose"]
    total = result.summary["total_frames"]
    first = min(m.header.capture_time_ns for m in fits)
    last = max(m.header.publish_time_ns for m in fits)
    lat = [(m.header.publish_time_ns - m.header.capture_time_ns) / 1e6 for m in poses]
    p50, p99 = np.percentile(lat, [50, 99]) if lat else (float("nan"),) * 2
    with_face = {(m.header.frame_index, m.face_id) for m in fits if len(m.landmarks)}
    posed = {(m.header.frame_index, m.face_id) for m in poses}
    answered = len({m.header.frame_index for m in fits}) == total and with_face <= posed
    return Pacing((total - 1) / ((last - first) / 1e9), float(p50), float(p99), answered,
                  result.summary["messages"]["overlay"], len(poses),
                  sum(m.reliable for m in poses))


def stack_cpu(result: RunResult) -> float:
    return sum(v for v in result.cpu.values() if np.isfinite(v))


def service_table(runs: dict[str, RunResult]) -> str:
    names = sorted({n for r in runs.values() for n in r.cpu},
                   key=lambda n: -max(r.cpu.get(n, 0) for r in runs.values()))
    head = f"{'process':<12}" + "".join(f" {label + ' ms/frame':>22}" for label in runs)
    lines = [head]
    for name in names:
        row = f"{name:<12}"
        for r in runs.values():
            row += f" {1000 * r.cpu.get(name, float('nan')) / r.summary['total_frames']:>22.2f}"
        lines.append(row)
    lines.append(f"{'all':<12}" + "".join(
        f" {1000 * stack_cpu(r) / r.summary['total_frames']:>22.2f}" for r in runs.values()))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__)
    parser.add_argument("--plays", type=int, default=3, help="forward-backward plays, long clip")
    parser.add_argument("--warp", choices=("auto", "gpu", "cpu"), default="auto")
    args = options.parse(parser, argv)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    print(f"load before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}; "
          f"{os.cpu_count()} cores")
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)
        source = data_root() / "videos" / "single_face.mp4"
        short, long = tmp / "short.mp4", tmp / "long.mp4"
        n_short, n_long = ping_pong(source, short, 1), ping_pong(source, long, args.plays)
        lib = {clip: library_cpu(clip) for clip in (short, long)}
        real = {clip: stack_run(clip, "realtime", args.warp, tmp) for clip in (short, long)}
        fast = stack_run(long, "fast", args.warp, tmp)
    lib_ms = 1000 * (lib[long][1] - lib[short][1]) / (lib[long][0] - lib[short][0])
    stack_ms = 1000 * (stack_cpu(real[long]) - stack_cpu(real[short])) / (n_long - n_short)
    ratio = stack_ms / lib_ms
    rt, fa = pacing(real[long]), pacing(fast)
    drawn = fa.overlays / max(fa.reliable, 1)
    print(f"clips: single_face.mp4 forward-backward, {n_short} and {n_long} frames")
    print(f"\nmarginal CPU a frame ({n_long} - {n_short} frames, every process and thread, "
          f"decode included): library {lib_ms:.2f} ms, stack at real-time pacing "
          f"{stack_ms:.2f} ms: {ratio:.2f} x")
    print(f"\nper process (CPU ms a frame):\n"
          f"{service_table({'real-time': real[long], 'fast': fast})}")
    print(f"\nfast pacing: {fa.fps:.1f} frames/s; overlays {fa.overlays} for {fa.reliable} "
          f"reliable poses ({drawn:.1%}) of {fa.poses}; capture to pose p50 {fa.p50:.1f} ms, "
          f"p99 {fa.p99:.1f} ms; every frame answered: {fa.answered}")
    print(f"real-time pacing: capture to pose p50 {rt.p50:.1f} ms, p99 {rt.p99:.1f} ms; "
          f"every frame answered: {rt.answered}")
    print(f"source: {fast.summary['services']['source']['message']}")
    print(f"load after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}\n")
    checks = [RATIO.check(ratio, f"{stack_ms:.1f} / {lib_ms:.1f} ms"), FAST_FPS.check(fa.fps),
              OVERLAYS.check(100 * drawn, f"{fa.overlays} of {fa.reliable}"),
              FAST_P99.check(fa.p99, f"p50 {fa.p50:.0f} ms"),
              REALTIME_P99.check(rt.p99, f"p50 {rt.p50:.0f} ms"),
              REALTIME_ANSWERED.check(bool(rt.answered))]
    return 0 if all(checks) else 1
