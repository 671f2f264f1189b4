"""Flood bench (issue 42): the memory a flood of bad messages leaves behind.

Run: ``OMP_NUM_THREADS=1 python -m bench flood [--flood-s 20]
[--small-model]``

The stack (no AR) on ``single_face.mp4`` looped in real time; after ``--warm-s`` a program on
the run's bus floods every key the services read with malformed payloads and unsigned
frames of the full size, as fast as it can, for ``--flood-s``; the run goes on for
``--after-s`` more. Every second the resident set size (``VmRSS``) of each service and of
the launcher (this process) is read. The table gives the baseline (the mean of the last 5 s
before the flood), the peak during it and the value ``--after-s`` after it ended. Target:
every process back within 10 % of its baseline 10 s after the flood ends.
"""

from __future__ import annotations

import os
import threading
import time

import numpy as np

from aamcore.config import data_root
from bench import options
from bench.bench_soak import rss_mb
from bench.targets import Target
from proto import Frame, Header, encode
from services.bus.connection import BusOptions
from services.bus.session import Service
from services.stack.launcher import Stack, prepared
from services.stack.options import parse_run_args

MEMORY = Target("every process's memory after the flood, against its baseline (worst)", "<=",
                1.10, "x")
TARGETS = (MEMORY,)


def flood(intruder: Service, run: str, until: float) -> int:
    """Bad messages on every key read, until ``until`` (monotonic); how many were sent."""
    frame = encode(Frame.from_array(Header.now(intruder.stream, 0, "source", run_id=run),
                                    np.zeros((360, 640, 3), np.uint8)))
    keys = [intruder.key(k) for k in ("frame", "fit", "pose", "eos")]
    sent = 0
    while time.monotonic() < until:
        for key in keys:
            intruder.put(key, b"\xc1" + os.urandom(2000))  # malformed
            intruder.put(key, frame)  # well formed, unsigned, 691 KB
            sent += 2
    return sent


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__, model=True)
    parser.add_argument("--warm-s", type=float, default=30.0)
    parser.add_argument("--flood-s", type=float, default=20.0)
    parser.add_argument("--after-s", type=float, default=10.0)
    parser.add_argument("--small-model", action="store_true")
    args = options.parse(parser, argv)
    video = data_root() / "videos" / "single_face.mp4"
    argv = ["--video", str(video), "--no-ar", "--loop", "1000", "--pace", "realtime"]
    if args.model:
        argv += ["--model", str(args.model)]
    elif args.small_model:
        from aamcore.expression.training import classifier_path
        from aamcore.fitting.training.prepare import default_model_path

        model = default_model_path(max_images=10, limit=300)
        argv += ["--model", str(model), "--classifier", str(classifier_path(model))]
    opts = prepared(parse_run_args(argv))
    samples: dict[str, list[tuple[float, float]]] = {}
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    with Stack(opts) as stack, Service(
            "intruder", BusOptions(opts.launch.stream, listen=("tcp/127.0.0.1:0",),
                                   connect=(stack.endpoint,)), handle_signals=False,
            announce=False) as intruder:
        start = time.monotonic()
        flood_at, flood_end = start + args.warm_s, start + args.warm_s + args.flood_s
        stop = flood_end + args.after_s
        sent = [0]
        thread = threading.Thread(target=lambda: (time.sleep(args.warm_s), sent.__setitem__(
            0, flood(intruder, stack.run_id, flood_end))), daemon=True)
        thread.start()
        while time.monotonic() < stop:
            now = time.monotonic() - start
            pids = {s.name: stack.supervisor.pid(s.name) for s in stack.specs}
            pids["launcher"] = os.getpid()
            for name, pid in pids.items():
                if pid is not None:
                    samples.setdefault(name, []).append((now, rss_mb(pid)))
            time.sleep(1.0)
        thread.join(30)
        stack.service.request_stop("the bench is over")
    warm, end = flood_at - start, flood_end - start
    print(f"{sent[0]} bad messages in {args.flood_s:g} s")
    print(f"{'process':<12}{'before MB':>10}{'peak MB':>9}{'after MB':>9}{'after/before':>14}")
    worst = 0.0
    for name, series in samples.items():
        before = [v for t, v in series if warm - 5 <= t < warm]
        during = [v for t, v in series if warm <= t <= end]
        after = [v for t, v in series if t >= end + args.after_s - 1.5]
        if not before or not after:
            continue
        base = float(np.mean(before))
        ratio = after[-1] / base
        worst = max(worst, ratio)
        print(f"{name:<12}{base:>10.1f}{max(during or [base]):>9.1f}{after[-1]:>9.1f}"
              f"{ratio:>14.3f}")
    return 0 if MEMORY.check(worst, f"{args.after_s:g} s after the flood") else 1

