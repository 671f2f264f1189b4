"""Progress of long work (training, tracking a video, exporting a run), whatever the output.

On a terminal a bar (tqdm, on standard error); elsewhere (a log, CI, a pipe) a line when the
work starts, one every :data:`LINE_EVERY_S` seconds with what is done of the total, the rate
and the time left, and one when it ends. ``AAMTRACK_PROGRESS=0`` turns both off,
``AAMTRACK_PROGRESS=1`` asks for bars without a terminal.

Training declares its phases up front (:func:`plan`): each then reads "phase k of n", with the
time left for the whole, estimated from the phases' expected durations scaled by how fast
the done ones went. While work is under way nothing stays silent for more than
:data:`LINE_EVERY_S` (plus a tick): a background ticker keeps a bar's clock moving through a
slow step and prints a line where no bar is shown.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, TypeVar

T = TypeVar("T")

LINE_EVERY_S = 10.0
"""Seconds between two progress lines; also the longest silence while work goes on."""


def mode() -> str:
    """``"bar"``, ``"lines"`` or ``"off"``."""
    flag = os.environ.get("AAMTRACK_PROGRESS", "")
    if flag:
        return "off" if flag in ("0", "false", "no") else "bar"
    return "bar" if sys.stderr.isatty() else "lines"


def enabled() -> bool:
    """Whether progress bars are shown."""
    return mode() == "bar"


def duration(seconds: float) -> str:
    """``seconds`` for people: ``"8 s"``, ``"2 min 05 s"``, ``"1 h 02 min"``."""
    s = max(int(round(seconds)), 0)
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"


def note(text: str) -> None:
    """A line for the user about a long step (standard error)."""
    _Ticker.spoke()
    print(f"aamtrack: {text}", file=sys.stderr, flush=True)


class Plan:
    """The phases of one long job, in order, each with its expected seconds on a quiet
    two-core machine (only their ratios matter once a phase is done)."""

    def __init__(self, title: str, phases: Sequence[tuple[str, float]],
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.title = title
        self.names = [name for name, _ in phases]
        self.expected = dict(phases)
        self.clock = clock
        self.started = clock()
        self.k = 0
        self.current = ""
        self.phase_started = self.started
        self._spent = self._spent_expected = 0.0

    def start(self, name: str) -> str:
        """Phase ``name`` begins (a phase not planned is added here); its label."""
        now = self.clock()
        if self.current:
            self._spent += now - self.phase_started
            self._spent_expected += self.expected.get(self.current, 0.0)
        if name in self.names[self.k:]:
            del self.names[self.k:self.names.index(name, self.k)]  # planned, skipped
        else:
            self.names.insert(self.k, name)
        self.k += 1
        self.current, self.phase_started = name, now
        return self.label()

    def label(self) -> str:
        return f"{self.title}, phase {self.k} of {len(self.names)}: {self.current}"

    def status(self) -> str:
        """Where the job is between two phases' progress, and its time left."""
        spent = self.clock() - self.started
        where = (f"after phase {self.k} of {len(self.names)} ({self.current})" if self.k
                 else "starting")
        return (f"{self.title}: {where}, {duration(spent)} in, about {duration(self.left())} "
                "left in all")

    def left(self, share_done: float | None = None) -> float:
        """Estimated seconds to the end, ``share_done`` of the current phase being done."""
        spent = self.clock() - self.phase_started
        expected = self.expected.get(self.current, 0.0)
        done, done_expected = self._spent, self._spent_expected
        if share_done:  # the current phase's pace counts for its share done
            done, done_expected = done + spent, done_expected + share_done * expected
        pace = done / done_expected if done_expected > 0 else 1.0
        rest = pace * sum(self.expected.get(n, 0.0) for n in self.names[self.k:])
        if share_done:
            return rest + spent * (1.0 - share_done) / share_done
        return rest + max(pace * expected - spent, 0.0)


class Meter:
    """Progress of ``total`` items (None: unknown), shown as :func:`mode` says.

    ``update(done)`` sets the count, ``close()`` ends it (with a last line unless
    ``summary=False``, for a command that says what it did itself).
    """

    def __init__(self, desc: str, total: int | None = None, unit: str = "item",
                 summary: bool = True) -> None:
        self.shown = mode()
        self.plan = _Ticker.plan if self.shown != "off" else None
        self.desc = self.plan.start(desc) if self.plan else desc
        self.total = total or None
        self.unit, self.summary = unit, summary
        self.done = 0
        self.started = time.monotonic()
        self._bar = None
        if self.shown == "bar":
            from tqdm import tqdm

            self._bar = tqdm(desc=self.desc, total=self.total, unit=unit, file=sys.stderr,
                             leave=False, dynamic_ncols=True)
        elif self.shown == "lines":
            note(f"{self.desc}: started" + (f" ({_count(total, unit)})" if total else ""))
        if self.shown != "off":
            _Ticker.hold(self)

    def update(self, done: int) -> None:
        if self._bar is not None and done != self.done:
            self._bar.update(done - self.done)
        self.done = done

    def status(self) -> str:
        """What is done, how fast, and the time left."""
        spent = time.monotonic() - self.started
        share = self.done / self.total if self.total else None
        parts = []
        if self.total:
            parts.append(f"{self.done} of {_count(self.total, self.unit)} ({share:.0%})")
        elif self.done:
            parts.append(_count(self.done, self.unit))
        if self.done:
            parts.append(_rate(self.done, spent, self.unit))
        parts.append(f"{duration(spent)} in")
        left = (self.plan.left(share) if self.plan else
                spent * (1 - share) / share if share else None)
        if left is not None:
            parts.append(f"about {duration(left)} left" + (" in all" if self.plan else ""))
        return f"{self.desc}: " + ", ".join(parts)

    def refresh(self) -> None:
        if self._bar is not None:
            self._bar.refresh()

    def close(self, finished: bool = True) -> None:
        """End the display; the last line only when the work ``finished`` (not when it was
        interrupted)."""
        if self.shown == "off":
            return
        _Ticker.release(self)
        if self._bar is not None:
            self._bar.close()
        if finished and self.summary and self.shown == "lines":
            spent = time.monotonic() - self.started
            note(f"{self.desc}: done, {_count(self.done, self.unit)} in {duration(spent)} "
                 f"({_rate(self.done, spent, self.unit)})")


def _count(n: int, unit: str) -> str:
    return f"{n} {unit}" + ("" if n == 1 else "s")


def _rate(done: int, seconds: float, unit: str) -> str:
    if done == 0 or seconds <= 0:
        return f"0 {unit}s/s"
    per_second = done / seconds
    return f"{per_second:.1f} {unit}s/s" if per_second >= 1 else f"{1 / per_second:.1f} s/{unit}"


def progress(items: Iterable[T], desc: str, total: int | None = None, unit: str = "item",
             summary: bool = True) -> Iterator[T]:
    """``items`` with their progress shown (:class:`Meter`), labelled ``desc``."""
    if mode() == "off":
        yield from items
        return
    if total is None and hasattr(items, "__len__"):
        total = len(items)  # type: ignore[arg-type]
    meter = Meter(desc, total, unit, summary)
    finished = False
    try:
        for done, item in enumerate(items, 1):
            yield item
            meter.update(done)
        finished = True
    finally:
        meter.close(finished)


def bar(desc: str) -> Callable[[Iterable[T]], Iterator[T]]:
    """A wrapper that shows the progress of a phase labelled ``desc``: the ``progress``
    argument of the trainers."""
    return lambda items: progress(items, desc)


@contextmanager
def plan(title: str, phases: Sequence[tuple[str, float]]) -> Iterator[Plan | None]:
    """Number the phases that start inside (:class:`Plan`): ``phases`` are their names (the
    ``desc`` of their :func:`progress`, or :func:`phase`) with their expected seconds."""
    if mode() == "off" or _Ticker.plan is not None:  # one numbering: the outermost job's
        yield None
        return
    _Ticker.plan = Plan(title, phases)
    note(f"{title}: {len(phases)} phases, about {duration(_Ticker.plan.left())} on a quiet "
         "two-core machine")
    _Ticker.hold(None)
    finished = False
    try:
        yield _Ticker.plan
        finished = True
    finally:
        _Ticker.release(None)
        spent = time.monotonic() - _Ticker.plan.started
        _Ticker.plan = None
        if finished:
            note(f"{title}: done in {duration(spent)}")


@contextmanager
def phase(name: str) -> Iterator[None]:
    """A phase of work without items to count: numbered in the plan, its time counted,
    lines while it runs."""
    meter = Meter(name, None, "step", summary=False) if mode() != "off" else None
    try:
        yield
    finally:
        if meter is not None:
            meter.close(finished=False)


class _Ticker:
    """The one background thread that keeps long work from going silent."""

    plan: Plan | None = None
    _meters: list[Any] = []
    _lock = threading.Lock()
    _thread: threading.Thread | None = None
    _wake = threading.Event()
    _last = 0.0

    @classmethod
    def spoke(cls) -> None:
        cls._last = time.monotonic()

    @classmethod
    def hold(cls, meter: Meter | None) -> None:
        with cls._lock:
            cls._meters.append(meter)
            cls._wake.set()  # a sleeping ticker takes the new period
            if cls._thread is None or not cls._thread.is_alive():
                cls._thread = threading.Thread(target=cls._run, name="aamtrack-progress",
                                               daemon=True)
                cls._thread.start()

    @classmethod
    def release(cls, meter: Meter | None) -> None:
        with cls._lock:
            if meter in cls._meters:
                cls._meters.remove(meter)

    @classmethod
    def _run(cls) -> None:
        while True:
            cls._wake.wait(min(1.0, LINE_EVERY_S / 4))
            with cls._lock:
                cls._wake.clear()
                if not cls._meters:
                    cls._thread = None
                    return
                meter = next((m for m in reversed(cls._meters) if m is not None), None)
            if meter is not None and meter.shown == "bar":
                meter.refresh()
                cls.spoke()
            elif time.monotonic() - cls._last >= LINE_EVERY_S:
                if meter is not None:
                    note(meter.status())
                elif cls.plan is not None:
                    note(cls.plan.status())
