"""What a service counts and publishes in its status.

Counting rule: ``frames_in`` counts valid messages taken for processing,
``frames_out`` messages published, ``dropped`` messages skipped by design
(overwritten in a latest-only inbox, or skipped by the service), ``rejected``
messages that are not valid, ``ignored`` valid messages that are not the run's or not
vouched for (another run id, a producer that does not own the key, no signature of the
producer, stale or sent again: :data:`services.bus.trust.IGNORED`), ``failed`` valid
messages taken that could not be answered (an error while working on them) and
``lost`` frames that never arrived (gaps in the numbering of their run).
"""

from __future__ import annotations

import collections
import math
import re
import threading
from dataclasses import dataclass, field

import numpy as np

from proto import Header


class ReasonCounts:
    """What a service could not answer as asked, counted by the short key of the reason
    (the text before its first colon, numbers as ``#``), and the last reason with its
    frame."""

    def __init__(self) -> None:
        self.counts: collections.Counter[str] = collections.Counter()
        self.last = ""

    def add(self, reason: str, frame_index: int | None = None) -> None:
        key = re.sub(r"\d+", "#", reason.split(":", 1)[0]).strip()[:60]
        self.counts[key] += 1
        self.last = reason if frame_index is None else f"frame {frame_index}: {reason}"

    def total(self) -> int:
        return sum(self.counts.values())

    def line(self) -> str:
        """``"2 no face, 1 face in profile"``: the six most common."""
        return ", ".join(f"{n} {key}" for key, n in self.counts.most_common(6))


LATENCY_WINDOW = 300
"""Latencies kept for the status percentiles (about 10 s of video)."""


class LatencyWindow:
    """The latest :data:`LATENCY_WINDOW` latencies, in milliseconds."""

    def __init__(self, size: int = LATENCY_WINDOW) -> None:
        self._values: collections.deque[float] = collections.deque(maxlen=size)

    def add(self, ms: float) -> None:
        """Record one latency in milliseconds."""
        self._values.append(float(ms))

    def percentiles(self) -> tuple[float, float]:
        """``(p50, p99)`` in milliseconds; NaN before any value."""
        if not self._values:
            return math.nan, math.nan
        p50, p99 = np.percentile(np.fromiter(self._values, float), [50, 99])
        return float(p50), float(p99)


@dataclass
class ServiceStats:
    """Counts a service publishes in its status (see the module's counting rule)."""

    frames_in: int = 0
    frames_out: int = 0
    dropped: int = 0
    rejected: int = 0
    lost: int = 0
    ignored: int = 0
    failed: int = 0
    last_frame: int = 0
    last_capture_ns: int = 0
    latency: LatencyWindow = field(default_factory=LatencyWindow)
    ignored_by: collections.Counter[str] = field(default_factory=collections.Counter)
    """``ignored`` by reason (:data:`services.bus.trust.IGNORED`)."""

    def ignore(self, reason: str) -> None:
        """Count one message ignored for ``reason``."""
        self.ignored += 1
        self.ignored_by[reason] += 1

    def count_in(self, header: Header | None = None) -> None:
        """Count one message taken, remembering its frame index."""
        self.frames_in += 1
        if header is not None:
            self.last_frame = header.frame_index
            self.last_capture_ns = header.capture_time_ns


class FrameNumbering:
    """Counts the frames of each run that never arrived, from gaps in their indices.

    A restarted process (``from_first``) counts from the first frame it sees: the frames
    before it went to its predecessor, or to nobody, which the launcher tells from the
    fits it got.
    """

    def __init__(self, stats: ServiceStats, from_first: bool = False) -> None:
        self._stats = stats
        self._from_first = from_first
        self._run: str | None = None
        self._next = 0
        self._lock = threading.Lock()

    def arrived(self, header: Header) -> None:
        """Note the arrival of a frame (any order; a new run starts counting afresh)."""
        with self._lock:
            if header.run_id != self._run:
                first = self._from_first and self._run is None
                self._run, self._next = header.run_id, header.frame_index if first else 0
            index = header.frame_index
            if index > self._next:
                self._stats.lost += index - self._next
            self._next = max(self._next, index + 1)
