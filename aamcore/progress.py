"""Progress of the long steps (training, detection over a dataset), whatever the output.

On a terminal a bar per phase (tqdm, on standard error); elsewhere (a log, CI, a pipe)
a line at the start and the end of each phase and, for a long one, at its quarters with
the share done, so that a first run that trains for minutes is never silent. ``AAMTRACK_PROGRESS=0``
turns both off, ``AAMTRACK_PROGRESS=1`` asks for bars without a terminal.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from typing import TypeVar

T = TypeVar("T")

LINE_EVERY_S = 10.0
"""Least seconds between two lines of a phase (without a known length, their period)."""


def mode() -> str:
    """``"bar"``, ``"lines"`` or ``"off"``."""
    flag = os.environ.get("AAMTRACK_PROGRESS", "")
    if flag:
        return "off" if flag in ("0", "false", "no") else "bar"
    return "bar" if sys.stderr.isatty() else "lines"


def enabled() -> bool:
    """Whether progress bars are shown."""
    return mode() == "bar"


def progress(items: Iterable[T], desc: str, total: int | None = None) -> Iterator[T]:
    """``items`` with their progress shown as :func:`mode` says, labelled ``desc``."""
    shown = mode()
    if shown == "off":
        yield from items
        return
    if total is None and hasattr(items, "__len__"):
        total = len(items)  # type: ignore[arg-type]
    if shown == "lines":
        yield from _lines(items, desc, total)
        return
    from tqdm import tqdm

    yield from tqdm(items, desc=desc, total=total, unit="img", file=sys.stderr, leave=False)


def _lines(items: Iterable[T], desc: str, total: int | None) -> Iterator[T]:
    """A line when the phase starts, at each quarter that comes :data:`LINE_EVERY_S` or
    more after the line before (at that period without a known length), and when it ends."""
    started = last = time.monotonic()
    note(f"{desc}: started" + (f" ({total} items)" if total else ""))
    quarter, done = 0, 0
    for item in items:
        yield item
        done += 1
        now = time.monotonic()
        if now - last < LINE_EVERY_S:
            continue
        if total and 4 * done // total > quarter:
            quarter = 4 * done // total
            last = now
            note(f"{desc}: {done / total:.0%} ({done} of {total}, {now - started:.0f} s)")
        elif not total:
            last = now
            note(f"{desc}: {done} done ({now - started:.0f} s)")
    note(f"{desc}: done ({done} items in {time.monotonic() - started:.0f} s)")


def bar(desc: str) -> Callable[[Iterable[T]], Iterator[T]]:
    """A wrapper that shows the progress of a phase labelled ``desc``: the ``progress``
    argument of the trainers."""
    return lambda items: progress(items, desc)


def note(text: str) -> None:
    """A line for the user about a long step (standard error)."""
    print(f"aamtrack: {text}", file=sys.stderr, flush=True)
