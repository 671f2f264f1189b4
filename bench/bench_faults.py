"""Faults and overload: kill -9 each service during a run; feed the stack twice its rate.

1. **Kill -9.** The stack runs a looped video at its real frame rate. Each
   service in turn is killed with SIGKILL (its pid from the launcher's
   supervisor); the bench measures the time until a new process of it holds
   its liveliness token again (target: under 2 s) and the frames published
   while it was down that never got the result it produces (fit, pose,
   expression, overlay; for the detector, the fit).
2. **Overload.** The bench measures how fast the stack answers (fast pacing),
   writes a copy of the video whose frame rate is twice that (in a temporary
   folder, deleted afterwards) and plays it at that rate for ``--overload-s``
   seconds, sampling the resident memory of every process; memory growth
   after warm-up must stay under 5 % and the pose latency bounded.

Usage::

    python -m bench faults [--overload-s 90] [--warp gpu|cpu]

Prints a table per part; exits 1 if a target is missed.
"""

from __future__ import annotations

import logging
import os
import signal
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import msgpack
import numpy as np

from aamcore.config import data_root
from bench import options
from bench.targets import Target
from services.bus.connection import BusOptions
from services.bus.session import Service
from services.stack.launcher import Stack, free_port, prepared
from services.stack.options import StackOptions, parse_run_args

MODEL_LIMIT = 300
MODEL_IMAGES = 10
RECOVERY = Target("a killed service back (its liveliness token again)", "<", 2.0, "s")
FINISHED = Target("the run reaches its end of stream after the kills", "==", True)
GROWTH = Target("memory growth after warm-up, worst process, overload", "<", 5.0, "%")
BOUNDED = Target("pose latency bounded: second-half p99 < 2 x first-half's + 100 ms", "==",
                 True)
ACCOUNTED = Target("every frame answered or counted as dropped by the fitter", "==", True)
TARGETS = (RECOVERY, FINISHED, GROWTH, BOUNDED, ACCOUNTED)
KILLED = ("detector", "fitter", "pose", "expression", "ar")
RESULT_OF = {"detector": "fit", "fitter": "fit", "pose": "pose", "expression": "expression",
             "ar": "overlay"}
"""The per-frame result that shows a killed service's stage is working."""


@dataclass
class Observer:
    """Frame indices seen per kind, with the time each frame was published."""

    published_at: dict[int, float] = field(default_factory=dict)
    answered: dict[str, set[int]] = field(default_factory=dict)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def on_sample(self, sample: Any) -> None:
        kind = str(sample.key_expr).rsplit("/", 1)[-1]
        try:
            index = int(msgpack.unpackb(sample.payload.to_bytes(), raw=False)["header"][
                "frame_index"])
        except (ValueError, KeyError, TypeError, msgpack.UnpackException):
            return
        with self.lock:
            if kind == "frame":
                self.published_at.setdefault(index, time.monotonic())
            else:
                self.answered.setdefault(kind, set()).add(index)

    def frames_between(self, t0: float, t1: float) -> set[int]:
        with self.lock:
            return {i for i, t in self.published_at.items() if t0 <= t <= t1}


def stack_options(video: Path, warp: str, **kw: Any) -> StackOptions:
    argv = ["--video", str(video), "--model-limit", str(MODEL_LIMIT), "--model-images",
            str(MODEL_IMAGES), "--warp", warp, "--endpoint", f"tcp/127.0.0.1:{free_port()}",
            "--stream", "bench", "--drain-max", "10"]
    for name, value in kw.items():
        argv += ["--" + name.replace("_", "-"), str(value)]
    return prepared(parse_run_args(argv))


def wait_alive(probe: Service, names: set[str], timeout: float) -> bool:
    return not probe.wait_for_alive(names, timeout)


def recover(stack: Stack, probe: Service, name: str, timeout: float = 15.0) -> float:
    """Kill ``name`` with SIGKILL; seconds until a new process of it holds its token."""
    sup = stack.supervisor
    old = sup.pid(name)
    assert old is not None, f"{name} is not running"
    killed_at = time.monotonic()
    os.kill(old, signal.SIGKILL)
    while time.monotonic() - killed_at < timeout:
        pid = sup.pid(name)
        if pid is not None and pid != old and name in probe.alive():
            return time.monotonic() - killed_at
        time.sleep(0.01)
    return float("nan")


def kill_each(video: Path, warp: str) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Part 1; a row per killed service and the run's summary."""
    opts = stack_options(video, warp, pace="realtime", loop=20)
    observer = Observer()
    rows: list[dict[str, Any]] = []
    with Stack(opts) as stack:
        bus = BusOptions("bench", listen=("tcp/127.0.0.1:0",), connect=(stack.endpoint,))
        with Service("faultbench", bus, handle_signals=False) as probe:
            for kind in ("frame", "fit", "pose", "expression", "overlay"):
                probe.subscribe(probe.key(kind), observer.on_sample)
            waiter = threading.Thread(target=stack.wait, daemon=True)
            waiter.start()  # it also runs the supervisor's restarts
            assert wait_alive(probe, set(KILLED), 120), "stack did not start"
            time.sleep(4.0)  # warm up: tracking established
            for name in KILLED:
                killed_at = time.monotonic()
                took = recover(stack, probe, name)
                back_at = time.monotonic()
                time.sleep(3.0)  # let the stage answer the frames it still holds
                frames = observer.frames_between(killed_at, back_at)
                with observer.lock:
                    got = observer.answered.get(RESULT_OF[name], set())
                    dropped = len(frames - got)
                rows.append({"service": name, "recovery_s": took, "frames_down": len(frames),
                             "dropped": dropped, "restarts": stack.supervisor.restarts(name)})
            waiter.join()
    summary = stack.summary()
    summary["answered"] = {k: len(v) for k, v in observer.answered.items()}
    summary["published"] = len(observer.published_at)
    return rows, summary


def stack_rate(video: Path, warp: str) -> tuple[float, int]:
    """Fits per second the stack answers with fast pacing (between its first and last fit),
    and the number of fits."""
    times: list[float] = []
    with Stack(stack_options(video, warp, pace="fast", loop=3)) as stack:
        stack.service.subscribe(stack.service.key("fit"), lambda _: times.append(
            time.monotonic()))
        stack.wait()
    if len(times) < 2:
        raise RuntimeError("the stack answered no frames: cannot measure its rate")
    return (len(times) - 1) / (times[-1] - times[0]), len(times)


def rewrite_at(video: Path, fps: float, out: Path) -> int:
    """Copy ``video`` to ``out`` with frame rate ``fps``; its frame count."""
    cap = cv2.VideoCapture(str(video))
    ok, frame = cap.read()
    h, w = frame.shape[:2]
    # MJPG: mp4v's time base cannot express frame rates above about 65 fps.
    writer = cv2.VideoWriter(str(out), cv2.VideoWriter_fourcc(*"MJPG"), fps, (w, h))
    if not writer.isOpened():
        raise RuntimeError(f"cannot write {out} at {fps:.1f} fps")
    n = 0
    while ok:
        writer.write(frame)
        n += 1
        ok, frame = cap.read()
    cap.release()
    writer.release()
    return n


def rss_kb(pid: int) -> int | None:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    except OSError:
        return None
    return None


def overload(video: Path, warp: str, seconds: float, rate: float) -> dict[str, Any]:
    """Part 2: play at twice ``rate`` for ``seconds``; RSS per process over time."""
    fps = 2.0 * rate
    with tempfile.TemporaryDirectory() as tmp:
        fast = Path(tmp) / "overload.avi"
        n = rewrite_at(video, fps, fast)
        loops = int(np.ceil(seconds * fps / n)) + 1
        opts = stack_options(fast, warp, pace="realtime", loop=loops, max_frames=int(seconds * fps))
        samples: dict[str, list[tuple[float, int]]] = {}
        with Stack(opts) as stack:
            waiter = threading.Thread(target=stack.wait, daemon=True)
            waiter.start()
            t0 = time.monotonic()
            while waiter.is_alive():
                now = time.monotonic() - t0
                pids = {n: stack.supervisor.pid(n) for n in (*KILLED, "source")}
                pids["launcher"] = os.getpid()
                for name, pid in pids.items():
                    kb = rss_kb(pid) if pid else None
                    if kb is not None:
                        samples.setdefault(name, []).append((now, kb))
                latencies = list(stack.monitor.pose_latency_ms)
                waiter.join(2.0)
            elapsed = time.monotonic() - t0
        summary = stack.summary()
    return {"fps": fps, "samples": samples, "summary": summary, "latencies": latencies,
            "seconds": seconds, "elapsed": elapsed}


def growth(series: list[tuple[float, int]], warmup: float) -> tuple[float, float, float]:
    """(RSS after warm-up MB, RSS at the end MB, growth fraction): means of the first and
    last 15 s after ``warmup`` s."""
    t = np.array([s[0] for s in series])
    kb = np.array([s[1] for s in series], float)
    after = t >= warmup
    if after.sum() < 4:
        return float("nan"), float("nan"), float("nan")
    ta, ka = t[after], kb[after]
    first = ka[ta <= ta[0] + 15].mean()
    last = ka[ta >= ta[-1] - 15].mean()
    return first / 1024, last / 1024, (last - first) / first


def report_kills(rows: list[dict[str, Any]], summary: dict[str, Any]) -> bool:
    """Print part 1's table and check its targets; whether every one was met."""
    ok = True
    print("## kill -9 each service (video at its frame rate, looped)")
    print(f"{'service':<11} {'recovery s':>10} {'frames down':>11} {'dropped':>8} "
          f"{'restarts':>8}")
    for r in rows:
        print(f"{r['service']:<11} {r['recovery_s']:>10.2f} {r['frames_down']:>11} "
              f"{r['dropped']:>8} {r['restarts']:>8}")
    fits = summary["answered"].get("fit", 0)
    print(f"run: outcome {summary['outcome']}, frames published {summary['published']} "
          f"(end of stream says {summary['total_frames']}), frames with a fit {fits}, "
          f"events: {'; '.join(summary['events'])}")
    for r in rows:
        ok &= RECOVERY.check(r["recovery_s"], r["service"])
    return FINISHED.check(summary["outcome"] == "done") and ok


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__)
    parser.add_argument("--overload-s", type=float, default=90.0, help="overload run length")
    parser.add_argument("--warmup-s", type=float, default=20.0, help="overload warm-up")
    parser.add_argument("--warp", choices=("gpu", "cpu"), default="gpu")
    parser.add_argument("--skip-kill", action="store_true", help="only the overload part")
    args = options.parse(parser, argv)
    logging.basicConfig(level=logging.ERROR)
    video = data_root() / "videos" / "single_face.mp4"
    ok = True

    if not args.skip_kill:
        ok &= report_kills(*kill_each(video, args.warp))

    rate, n_fits = stack_rate(video, args.warp)
    print(f"\nfast pacing: {n_fits} fits at {rate:.1f} fits/s")
    result = overload(video, args.warp, args.overload_s, rate)
    print(f"\n## overload: {result['fps']:.1f} fps in (2 x {rate:.1f} fps the stack answers), "
          f"{result['seconds']:.0f} s, warm-up {args.warmup_s:.0f} s; the source published "
          f"{(result['summary']['total_frames'] or 0) / result['elapsed']:.1f} fps")
    print(f"{'process':<11} {'RSS MB':>8} {'end MB':>8} {'growth':>8}")
    worst = 0.0
    for name, series in sorted(result["samples"].items()):
        first, last, g = growth(series, args.warmup_s)
        worst = max(worst, g) if not np.isnan(g) else float("inf")
        print(f"{name:<11} {first:>8.1f} {last:>8.1f} {100 * g:>7.1f}%")
    s = result["summary"]
    lat = np.array(result["latencies"])
    half = len(lat) // 2
    if half:
        p99a, p99b = np.percentile(lat[:half], 99), np.percentile(lat[half:], 99)
        print(f"pose latency p99: first half {p99a:.0f} ms, second half {p99b:.0f} ms")
    fitter = s["services"].get("fitter", {})
    print(f"frames {s['total_frames']}, with a fit {s['frames_with']['fit']}, fitter dropped "
          f"{fitter.get('dropped')} (counted), in {fitter.get('frames_in')}")
    ok &= GROWTH.check(100 * worst)
    if half:
        ok &= BOUNDED.check(bool(p99b < 2 * p99a + 100),
                            f"second-half p99 {p99b:.0f} ms, first-half {p99a:.0f} ms")
    accounted = bool(s["total_frames"]) and (
        fitter.get("frames_in", 0) + fitter.get("dropped", 0) >= s["total_frames"])
    ok &= ACCOUNTED.check(accounted)
    return 0 if ok else 1

