"""When a run's results are all in: the one rule the launcher and ``aamtrack record
--until-eos`` stop by."""

from __future__ import annotations

import math
import threading
import time
from typing import TYPE_CHECKING

from services.stack.registry import ANSWERS
from services.stack.tally import Tally

if TYPE_CHECKING:
    from proto import Message

DRAIN_QUIET = 0.75
"""Seconds without a result, once the last frame's fit has come, that end a run."""
DRAIN_UNPOSED = 4
"""A run with fits still owed a pose waits this many times ``drain_quiet`` (a pose dropped
by design never comes; one on a loaded machine or through a router comes late)."""
RECENT = 64
"""Frames behind the newest fit whose pose may still come (more than any inbox holds)."""
DRAIN_MAX = 20.0
"""Seconds after the end of stream after which a run ends whatever is missing."""
RESULTS = ANSWERS
"""Kinds whose arrival means the run is not quiet yet (:data:`.registry.ANSWERS`)."""


class EndOfRun:
    """After the stream's (first) end of stream: over once the last frame's fit has come and
    no result has come for ``drain_quiet`` s (``DRAIN_UNPOSED`` times longer while a fit
    with a face has no pose), or once ``drain_max`` s have passed.

    Feed it every message of the run with :meth:`saw` (from any thread).
    """

    def __init__(self, drain_quiet: float = DRAIN_QUIET, drain_max: float = DRAIN_MAX) -> None:
        self.drain_quiet = drain_quiet
        self.drain_max = drain_max
        self.fits = Tally()
        """The frames with a fit (the latest :data:`.tally.WINDOW`)."""
        self.total: int | None = None
        self.eos_at = math.inf
        self.last = time.monotonic()
        self.unposed: set[tuple[int, int]] = set()
        """(frame index, face id) of fits with landmarks whose pose has not come."""
        self.early: set[tuple[int, int]] = set()
        """Poses that came before their fit (another path through a router)."""
        self.posing = False
        """Whether the run has a pose service (a pose has come)."""
        self._lock = threading.Lock()

    def saw(self, msg: Message) -> None:
        with self._lock:
            if msg.KIND in RESULTS:
                self.last = time.monotonic()
                key = (msg.header.frame_index, getattr(msg, "face_id", 0))
                if msg.KIND == "fit":
                    self.fits.add(msg.header.frame_index)
                    if len(msg.landmarks) and key not in self.early:
                        self.unposed.add(key)
                    self.early.discard(key)
                    if len(self.unposed) > 2 * RECENT:  # an older fit's pose was dropped
                        newest = max(i for i, _ in self.unposed)
                        self.unposed = {k for k in self.unposed if k[0] > newest - RECENT}
                elif msg.KIND == "pose":
                    self.posing = True
                    if key in self.unposed:
                        self.unposed.discard(key)
                    elif len(self.early) < 2 * RECENT:
                        self.early.add(key)
            elif msg.KIND == "eos":  # the first one starts the wait
                self.eos_at = min(self.eos_at, time.monotonic())
                self.total = msg.total_frames

    def over(self) -> bool:
        with self._lock:
            if self.total is None:
                return False
            now = time.monotonic()
            complete = self.total == 0 or self.total - 1 in self.fits
            quiet = self.drain_quiet * (DRAIN_UNPOSED if self.posing and self.unposed else 1)
            return (complete and now - self.last >= quiet) or (
                now - self.eos_at >= self.drain_max)
