"""The ``.rrd`` files of a run's Rerun logger: one part per process, each finished with its
footer, also the part of a process that was killed.

A logger closes its file with Rerun's footer (:mod:`services.rerun_logger.recording`). A
logger that is killed (SIGKILL, a crash) cannot: its part ends without the footer, perhaps
in the middle of a message, and ``rerun rrd verify`` refuses it. The launcher finishes such
a part when the run is over with ``rerun rrd migrate``, which reads what the file holds up
to the cut and writes it again with its footer; nothing that was written is lost.

This module does not import ``rerun``: the launcher uses it.
"""

from __future__ import annotations

import importlib.util
import subprocess
from pathlib import Path

FINISH_TIMEOUT_S = 600.0
"""Longest a part may take to finish (``rerun rrd migrate`` reads about 20 MB/s)."""


def part_path(rrd: str | Path, restarts: int) -> Path:
    """Where a logger restarted ``restarts`` times writes: never over an earlier part
    (``run.rrd``, then ``run.part1.rrd``, ``run.part2.rrd``...)."""
    path = Path(rrd)
    return path if restarts == 0 else path.with_name(f"{path.stem}.part{restarts}{path.suffix}")


def unfinished_parts(rrd: str | Path, restarts: int, closed: set[int]) -> list[Path]:
    """The parts of a logger restarted ``restarts`` times that exist and that their process
    did not close: those not in ``closed`` (the restart counts of the processes that said
    they closed theirs)."""
    parts = (part_path(rrd, k) for k in range(restarts + 1) if k not in closed)
    return [p for p in parts if p.is_file()]


def rerun_cli(*args: str) -> str:
    """Run the Rerun command line (the binary of the ``rerun-sdk`` package: ``python -m
    rerun_cli`` would not pass its exit code on); ``""`` when it succeeds, else its last
    line."""
    spec = importlib.util.find_spec("rerun_cli")
    if spec is None or spec.origin is None:
        return "the Rerun command line is not installed"
    try:
        done = subprocess.run([str(Path(spec.origin).with_name("rerun")), *args],
                              capture_output=True, text=True, timeout=FINISH_TIMEOUT_S)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return str(exc)
    if done.returncode == 0:
        return ""
    lines = [line.strip() for line in (done.stderr + done.stdout).splitlines() if line.strip()]
    cause = [line for line in lines if "os error" in line]  # the system's own word, if any
    return (cause or lines or [f"exit {done.returncode}"])[-1]


def finish(path: Path) -> str:
    """Write ``path`` again with its footer (``rerun rrd migrate``, which keeps the file as
    it was beside it until the new one verifies); ``""`` when done, else why not (the file
    is then left as it was: on a full disk, say)."""
    backup = path.with_name(f"{path.stem}.backup{path.suffix}")
    why = rerun_cli("rrd", "migrate", str(path)) or rerun_cli("rrd", "verify", str(path))
    if not why:
        backup.unlink(missing_ok=True)
    elif backup.is_file():
        backup.replace(path)
    return why
