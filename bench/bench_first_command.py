"""The README's first command on a fresh checkout with an empty model cache: its phases.

Run: ``OMP_NUM_THREADS=1 python -m bench first-command [--repo PATH]
[--keep]``

Clones the repository's committed HEAD into a temporary folder (no ``.venv``, no ``out/``),
runs ``./scripts/demo.sh`` there as the README says, with ``AAMTRACK_CACHE`` an empty
folder, and times each line of its output as it comes. The phases, told apart by the lines
that end them: set-up (``scripts/setup.sh``: the virtual environment and every
dependency), the default models' training (the fitting model and the expression
classifier, until the stack's bus is up), the stack on ``single_face.mp4`` (until its
summary), the check of its recording (``rerun rrd verify``) and the IMM model with its two
figures. Prints each phase's wall time, the whole command's wall and CPU time (every
process it started), the machine's load before and after, and any line that warns, then
the target: exit 0 in under 10 minutes on two cores, without a warning or a traceback
(issue 43). These are the figures the README gives.
"""

from __future__ import annotations

import os
import re
import resource
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

from bench import options
from bench.targets import Target

EXITS_0 = Target("the first command on a fresh clone, empty cache, exits 0", "==", True)
MINUTES = Target("the first command's wall time, training included", "<", 10.0, "min")
NOISE_LINES = Target("lines that warn or trace back", "==", 0)
TARGETS = (EXITS_0, MINUTES, NOISE_LINES)
NOISE = re.compile(r"warn|traceback|deprecat|error:|exception", re.IGNORECASE)
"""What no line of a clean run may hold (as ``tests/test_first_command.py`` checks)."""
PHASES = (
    ("set-up (.venv, dependencies)", "aamtrack"),
    ("default models trained", "stack bus at"),
    ("the stack on single_face.mp4", "end of stream:"),
    ("rerun rrd verify", "verified without error"),
    ("IMM model and its figures", None),
)
"""Each phase and what the line that ends it holds (the last ends with the command)."""


def run_timed(command: list[str], cwd: Path, env: dict[str, str]) -> tuple[int, list]:
    """Run ``command``; its exit code and ``(seconds since start, line)`` of every line."""
    started = time.monotonic()
    lines = []
    with subprocess.Popen(command, cwd=cwd, env=env, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, text=True, bufsize=1) as proc:
        assert proc.stdout is not None
        for line in proc.stdout:
            lines.append((time.monotonic() - started, line.rstrip("\n")))
    lines.append((time.monotonic() - started, ""))
    return proc.returncode, lines


def phase_ends(lines: list[tuple[float, str]]) -> list[float]:
    """When each of :data:`PHASES` ended (seconds), in order; NaN for one not seen."""
    ends, k = [], 0
    for _, marker in PHASES:
        if marker is None:
            ends.append(lines[-1][0])
            continue
        while k < len(lines) and marker not in lines[k][1]:
            k += 1
        ends.append(lines[k][0] if k < len(lines) else float("nan"))
        k = min(k, len(lines) - 1)
    return ends


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__)
    parser.add_argument("--repo", type=Path, default=Path(__file__).resolve().parent.parent,
                        help="the repository to clone (default: this one)")
    parser.add_argument("--keep", action="store_true", help="keep the clone and its cache")
    args = options.parse(parser, argv)
    work = Path(tempfile.mkdtemp(prefix="first-command-"))
    clone, cache = work / "aamtrack", work / "cache"
    cache.mkdir()
    subprocess.run(["git", "clone", "-q", str(args.repo), str(clone)], check=True)
    data = os.environ.get("AAMTRACK_DATA") or str(args.repo.parent / "shared" / "data")
    env = os.environ | {"AAMTRACK_CACHE": str(cache), "AAMTRACK_DATA": str(Path(data).resolve())}
    env.pop("VIRTUAL_ENV", None)
    load_before = os.getloadavg()[0]
    cpu = resource.getrusage(resource.RUSAGE_CHILDREN)
    code, lines = run_timed(["./scripts/demo.sh"], clone, env)
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_s = used.ru_utime + used.ru_stime - cpu.ru_utime - cpu.ru_stime
    load_after = os.getloadavg()[0]
    if code != 0:
        print("\n".join(line for _, line in lines[-30:]))
    ends = phase_ends(lines)
    print(f"./scripts/demo.sh on a fresh clone of {args.repo} ({clone}), empty model cache; "
          f"load {load_before:.1f} before, {load_after:.1f} after; exit {code}")
    print(f"{'phase':<32} {'wall s':>8} {'ends at':>8}")
    start = 0.0
    for (name, _), end in zip(PHASES, ends, strict=True):
        print(f"{name:<32} {end - start:>8.1f} {end:>8.1f}")
        start = end if end == end else start
    total = lines[-1][0]
    print(f"{'the whole command':<32} {total:>8.1f}   CPU {cpu_s:.1f} s "
          f"(every process it started)")
    noise = [line for _, line in lines if NOISE.search(line)]
    for line in noise:
        print(f"  noise: {line}")
    ok = EXITS_0.check(code == 0, f"exit {code}")
    ok &= MINUTES.check(total / 60, f"CPU {cpu_s:.0f} s, load {load_before:.1f} -> "
                                    f"{load_after:.1f}")
    ok &= NOISE_LINES.check(len(noise))
    if not args.keep:
        shutil.rmtree(work, ignore_errors=True)
    return 0 if ok else 1

