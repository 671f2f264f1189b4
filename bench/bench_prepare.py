"""Bench: ``aamtrack model prepare`` from an empty cache, phase by phase, wall and CPU time.

Run: ``python -m bench prepare [--no-classifier] [--runs 1] [--vs CHECKOUT]``

Each run is the whole command in a fresh, empty ``AAMTRACK_CACHE`` (a temporary folder,
removed after), with ``OMP_NUM_THREADS=1`` and progress as lines. Its standard error is read
as it comes: a line naming "phase k of n: NAME" starts a phase, the note "... trained in"
ends a job's last one; the wall time of each phase, and its CPU time (the command's process,
its threads included, from ``/proc``). The command's whole wall and CPU time (``getrusage``
of the children) close the table.

``--vs CHECKOUT`` runs the same command of another checkout (its ``.venv/bin/aamtrack``, in
its folder) in turn with this one's, run after run: on a shared machine the ratio of the
two, measured side by side, is the figure that a neighbour's load disturbs least.

Target (issue 47 item 5): the whole command (fitting model and expression classifier)
<= 3 minutes on a quiet two-core machine. The load average is printed with every run; a
loaded machine's wall time says little, its CPU time more.
"""

from __future__ import annotations

import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from bench import options
from bench.targets import Target

HERE = Path(__file__).resolve().parents[1]
PREPARE = Target("aamtrack model prepare (fitting model and classifier), empty cache, best "
                 "wall time, exit 0", "<=", 180.0, "s")
TARGETS = (PREPARE,)
PHASE = re.compile(r"aamtrack: (?P<title>[^,]+), phase \d+ of \d+: (?P<name>[^:]+):")
JOB_DONE = re.compile(r"aamtrack: (?P<what>.+) trained in \d+ s")
TICKS = os.sysconf("SC_CLK_TCK")


@dataclass
class Run:
    """One command's phases ``(title, name, wall s, cpu s)``, wall and CPU time, exit code."""

    checkout: Path
    phases: list[tuple[str, str, float, float]] = field(default_factory=list)
    wall: float = 0.0
    cpu: float = 0.0
    code: int = 0
    load: tuple[float, float] = (0.0, 0.0)


def _cpu_of(pid: int) -> float:
    """CPU seconds (user + system, all threads) of a live process; 0 once it is gone."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / TICKS


def run_prepare(checkout: Path, extra: list[str], keep: Path | None = None) -> Run:
    """``aamtrack model prepare`` of ``checkout`` in an empty cache (``keep``: that folder,
    kept after), timed phase by phase."""
    run = Run(checkout, load=(os.getloadavg()[0], 0.0))
    aamtrack = checkout / ".venv" / "bin" / "aamtrack"
    if keep is not None and keep.exists() and any(keep.iterdir()):
        raise SystemExit(f"{keep} is not empty: the cache must start empty")
    with tempfile.TemporaryDirectory(prefix="bench-prepare-") as temporary:
        cache = str(keep or temporary)
        env = {k: v for k, v in os.environ.items() if k != "AAMTRACK_PROGRESS"}  # lines
        env |= {"AAMTRACK_CACHE": cache, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(checkout)}
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        proc = subprocess.Popen([str(aamtrack), "model", "prepare", *extra], cwd=checkout,
                                env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                text=True)
        current: tuple[str, str, float, float] | None = None
        assert proc.stderr is not None
        for line in proc.stderr:
            now, cpu = time.perf_counter() - start, _cpu_of(proc.pid)
            found = PHASE.search(line)
            ended = JOB_DONE.search(line)
            if found and (current is None or current[:2] != (found["title"], found["name"])):
                if current is not None:
                    run.phases.append((*current[:2], now - current[2], cpu - current[3]))
                current = (found["title"], found["name"], now, cpu)
            elif ended and current is not None:
                run.phases.append((*current[:2], now - current[2], cpu - current[3]))
                current = None
            if line.startswith("aamtrack: error") or "Traceback" in line:
                print(line, end="", file=sys.stderr)
        run.code = proc.wait()
        run.wall = time.perf_counter() - start
        if current is not None:
            run.phases.append((*current[:2], run.wall - current[2], float("nan")))
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        run.cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    run.load = (run.load[0], os.getloadavg()[0])
    return run


def print_run(run: Run) -> None:
    print(f"\n{run.checkout}: exit {run.code}, load {run.load[0]:.1f} -> {run.load[1]:.1f}")
    print(f"  {'job':<28}{'phase':<28}{'wall s':>8}{'cpu s':>8}")
    for title, name, wall, cpu in run.phases:
        print(f"  {title[:27]:<28}{name[:27]:<28}{wall:8.1f}{cpu:8.1f}")
    counted = sum(p[2] for p in run.phases)
    print(f"  {'outside the phases':<56}{run.wall - counted:8.1f}")
    print(f"  {'the whole command':<56}{run.wall:8.1f}{run.cpu:8.1f}")


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__)
    parser.add_argument("--no-classifier", action="store_true",
                        help="the fitting model only (the target is for both)")
    parser.add_argument("--runs", type=int, default=1)
    parser.add_argument("--vs", type=Path, help="another checkout to run in turn with this one")
    parser.add_argument("--keep", type=Path,
                        help="an empty folder to train this checkout's models in, kept after "
                             "(one run, no --vs)")
    args = options.parse(parser, argv)
    if args.keep and (args.vs or args.runs > 1):
        parser.error("--keep trains one model: no --vs, one run")
    extra = ["--no-classifier"] if args.no_classifier else []
    checkouts = [HERE] + ([args.vs.resolve()] if args.vs else [])
    runs: dict[Path, list[Run]] = {c: [] for c in checkouts}
    for k in range(args.runs):
        for checkout in checkouts if k % 2 == 0 else checkouts[::-1]:
            run = run_prepare(checkout, extra, args.keep if checkout == HERE else None)
            print_run(run)
            runs[checkout].append(run)
    what = "fitting model" if args.no_classifier else "fitting model and classifier"
    print()
    for checkout, done in runs.items():
        walls = sorted(r.wall for r in done)
        cpus = sorted(r.cpu for r in done)
        print(f"{checkout}: prepare ({what}) wall {', '.join(f'{w:.0f}' for w in walls)} s, "
              f"CPU {', '.join(f'{c:.0f}' for c in cpus)} s")
    if args.vs:
        mine, theirs = runs[HERE], runs[args.vs.resolve()]
        ratios = [(a.wall / b.wall, a.cpu / b.cpu) for a, b in zip(mine, theirs, strict=True)]
        print("this / --vs, run by run: " + "; ".join(
            f"wall {w:.2f}, CPU {c:.2f}" for w, c in ratios))
    best = min(r.wall for r in runs[HERE])
    failed = any(r.code for rs in runs.values() for r in rs)
    load = f"load {min(r.load[0] for r in runs[HERE]):.1f}-{max(r.load[1] for r in runs[HERE]):.1f}"
    if args.no_classifier:  # the target is for both: the fitting model alone is information
        print(f"aamtrack model prepare ({what}), empty cache: {best:.0f} s wall ({load})")
        return 1 if failed else 0
    return 0 if PREPARE.check(float("inf") if failed else best, load) else 1

