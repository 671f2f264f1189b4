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

import subprocess
import sys
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


def finish(path: Path) -> str:
    """Write ``path`` again with its footer (``rerun rrd migrate``); "" when done, else why
    not (the file is then left as it was)."""
    backup = path.with_name(f"{path.stem}.backup{path.suffix}")
    try:
        done = subprocess.run([sys.executable, "-m", "rerun_cli", "rrd", "migrate", str(path)],
                              capture_output=True, text=True, timeout=FINISH_TIMEOUT_S)
    except (OSError, subprocess.TimeoutExpired) as exc:
        done = None
        why = str(exc)
    else:
        lines = (done.stderr or done.stdout).strip().splitlines()
        why = lines[-1] if lines else f"exit {done.returncode}"
    if done is not None and done.returncode == 0 and path.is_file():
        backup.unlink(missing_ok=True)
        return ""
    if backup.is_file():
        backup.replace(path)
    return why
