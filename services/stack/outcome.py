"""How a run ended, as an exit code and one line: what went unanswered, and why."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from services.stack.monitor import StackMonitor
    from services.stack.options import StackOptions

EXIT_OK, EXIT_FAILED, EXIT_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130


def unanswered_problem(summary: dict[str, Any]) -> str:
    """What went unanswered in a run that reached its end ("" when nothing did)."""
    owed = summary.get("unanswered", {})
    services = summary.get("services", {})
    parts = []
    for stage, service, what in (("fit", "fitter", "frames got no fit"),
                                 ("pose", "pose", "fits with a face got no pose")):
        if owed.get(stage, 0):
            s = services.get(service, {})
            why = ", ".join(f"{s[k]} {k}" for k in ("rejected", "lost", "failed") if s.get(k))
            restarts = f", {service} restarted {s['restarts']} times" if s.get("restarts") else ""
            parts.append(f"{owed[stage]} {what} ({why or 'never taken'}{restarts})")
    return "; ".join(parts)


def exit_code(outcome: str, summary: dict[str, Any]) -> int:
    """0 for a run that reached its end with every frame answered or dropped by design,
    else the reason's code, with a message."""
    reason = summary.get("eos_reason") or ""
    if outcome == "done" and not reason.startswith("error"):
        problem = unanswered_problem(summary)
        if problem:
            print(f"aamtrack run: error: {problem}", file=sys.stderr)
            return EXIT_FAILED
        return EXIT_OK
    if outcome.startswith("refused: "):  # a service could not be given its key safely
        print(f"aamtrack run: error: {outcome.removeprefix('refused: ')}", file=sys.stderr)
        return EXIT_INPUT
    if outcome == "stopped":
        print("aamtrack run: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    why = reason.removeprefix("error: ") if reason.startswith("error") else outcome
    print(f"aamtrack run: error: {why}", file=sys.stderr)
    return EXIT_FAILED


def output_problem(mon: StackMonitor) -> str:
    """Why a file the run writes can no longer be written (a full disk), or ``""``: the
    launcher's recording, or the Rerun logger's (its last status says)."""
    if mon.recorder is not None and mon.recorder.error:
        return f"--record {mon.recorder.error}; the messages before are kept"
    rerun = mon.statuses.get("rerun")
    if rerun is not None and rerun.state == "failed" and "cannot be written" in rerun.message:
        return f"--rrd {rerun.message}"
    return ""


def say_unwritten(opts: StackOptions) -> None:
    """One line for each recording the run was asked for that does not exist (stopped
    before it was started)."""
    for path in unwritten(opts):
        print(f"aamtrack run: no recording {path}: stopped before it was started",
              file=sys.stderr)


def unwritten(opts: StackOptions) -> list[str]:
    """The recording files the run was asked for that do not exist (stopped early)."""
    rerun = opts.services.get("rerun")
    asked = [opts.launch.record, rerun.rrd if rerun is not None else None]
    return [p for p in asked if p and not Path(p).exists()]
