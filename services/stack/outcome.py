"""How a run ended, as an exit code and one line: what went unanswered, and why."""

from __future__ import annotations

import sys
from typing import Any

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
