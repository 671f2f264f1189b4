"""Soak bench: every service's memory over a long run at the fastest pacing.

Run: ``OMP_NUM_THREADS=1 python -m bench soak [--minutes 10] [--small-model]
[--no-rerun]``

The default stack (detector, fitter, pose, expression, glasses renderer, Rerun logger
writing an ``.rrd``, source) on ``videos/single_face.mp4`` looped for ``--minutes`` at
``--pace fast``. Every 5 s the resident set size (``VmRSS``) of each service's process is
read from ``/proc``; the table gives it after the first minute (warm: models loaded,
caches filled) and at the end, the growth between them, and the peak. The AR row also
says how many reliable poses it drew and skipped. Target (issue 22): growth < 5 % per
service after the first minute.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

from aamcore.config import data_root
from bench import options
from bench.targets import Target
from services.stack.launcher import Stack, prepared
from services.stack.options import parse_run_args

GROWTH = Target("resident memory growth after the first minute, worst service", "<", 5.0,
                "%")
TARGETS = (GROWTH,)
WARM_S = float(os.environ.get("SOAK_WARM_S", "60"))
PERIOD_S = 5.0


def rss_mb(pid: int) -> float:
    """Resident set size of a process, MB (NaN once it is gone)."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return float("nan")


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__, model=True)
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--small-model", action="store_true")
    parser.add_argument("--no-rerun", action="store_true")
    args = options.parse(parser, argv)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    video = data_root() / "videos" / "single_face.mp4"
    seconds = 60.0 * args.minutes
    with tempfile.TemporaryDirectory() as tmp:
        argv_run = ["--video", str(video), "--pace", "fast", "--loop", "100000",
                    *(["--model-limit", "300", "--model-images", "10"] if args.small_model
                      else []),
                    *(["--model", str(args.model)] if args.model else []),
                    *([] if args.no_rerun else ["--rrd", str(Path(tmp) / "soak.rrd")])]
        opts = prepared(parse_run_args(argv_run))
        samples: dict[str, list[tuple[float, float]]] = {}
        with Stack(opts) as stack:
            started = time.monotonic()
            while (now := time.monotonic() - started) < seconds and not stack.service.wait(
                    PERIOD_S):
                for spec in stack.specs:
                    pid = stack.supervisor.pid(spec.name)
                    if pid is not None:
                        samples.setdefault(spec.name, []).append((now, rss_mb(pid)))
            summary = stack.monitor.summary()
            stack.service.request_stop("soak over")
    print(f"{args.minutes:g} min at the fastest pacing; frames with a fit "
          f"{summary['frames_with']['fit']}, overlays {summary['messages']['overlay']}")
    print(f"{'service':<12} {'MB at 1 min':>11} {'MB at end':>10} {'growth':>7} {'peak':>7}")
    worst = 0.0
    for name, series in sorted(samples.items()):
        warm = [mb for t, mb in series if t >= WARM_S]
        if not warm:
            continue
        growth = (warm[-1] - warm[0]) / warm[0]
        worst = max(worst, growth)
        print(f"{name:<12} {warm[0]:>11.1f} {warm[-1]:>10.1f} {growth:>7.1%} "
              f"{max(mb for _, mb in series):>7.1f}")
    ar = summary["services"].get("ar", {})
    print(f"ar: {ar.get('frames_out', 0)} overlays drawn, {ar.get('dropped', 0)} poses skipped; "
          f"{ar.get('message', '')}")
    return 0 if GROWTH.check(100 * worst) else 1

