"""When a run's results are all in: the one rule the launcher and ``aamtrack record
--until-eos`` stop by."""

from __future__ import annotations

import math
import threading
import time
from typing import TYPE_CHECKING

from services.stack.registry import ANSWERS

if TYPE_CHECKING:
    from proto import Message

DRAIN_QUIET = 0.75
"""Seconds without a result, once the last frame's fit has come, that end a run."""
DRAIN_MAX = 20.0
"""Seconds after the end of stream after which a run ends whatever is missing."""
RESULTS = ANSWERS
"""Kinds whose arrival means the run is not quiet yet (:data:`.registry.ANSWERS`)."""


class EndOfRun:
    """After the stream's (first) end of stream: over once the last frame's fit has come and
    no result has come for ``drain_quiet`` s, or once ``drain_max`` s have passed.

    Feed it every message of the run with :meth:`saw` (from any thread).
    """

    def __init__(self, drain_quiet: float = DRAIN_QUIET, drain_max: float = DRAIN_MAX) -> None:
        self.drain_quiet = drain_quiet
        self.drain_max = drain_max
        self.fits: set[int] = set()
        self.total: int | None = None
        self.eos_at = math.inf
        self.last = time.monotonic()
        self._lock = threading.Lock()

    def saw(self, msg: Message) -> None:
        with self._lock:
            if msg.KIND in RESULTS:
                self.last = time.monotonic()
                if msg.KIND == "fit":
                    self.fits.add(msg.header.frame_index)
            elif msg.KIND == "eos":  # the first one starts the wait
                self.eos_at = min(self.eos_at, time.monotonic())
                self.total = msg.total_frames

    def over(self) -> bool:
        with self._lock:
            if self.total is None:
                return False
            now = time.monotonic()
            complete = self.total == 0 or self.total - 1 in self.fits
            return (complete and now - self.last >= self.drain_quiet) or (
                now - self.eos_at >= self.drain_max)
