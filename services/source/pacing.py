"""When the source may publish the next frame.

- :class:`RealTimePacer`: frame ``k`` at ``start + k / fps`` (a late frame is
  published at once, never skipped: dropping is the consumers' choice).
- :class:`CreditWindow`: as fast as the stack consumes. The source may be at
  most ``window`` frames ahead of the last frame the stack answered (a fit
  published for it); a frame that gets no answer within ``timeout`` seconds
  is given up on so that a lost message cannot stall the stream.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

PACES = ("realtime", "fast")


class RealTimePacer:
    """Sleep until each frame's due time at ``fps`` frames per second.

    Parameters
    ----------
    fps : float
    sleep : callable
        ``sleep(seconds) -> bool``, returning True to abandon the wait (a stop).
    clock : callable
        Seconds on a monotonic clock (the one ``sleep`` waits on).
    """

    def __init__(self, fps: float, sleep: Callable[[float], bool],
                 clock: Callable[[], float] = time.monotonic) -> None:
        if not fps > 0:
            raise ValueError(f"fps must be positive, got {fps}")
        self.period = 1.0 / fps
        self._sleep = sleep
        self._clock = clock
        self._start: float | None = None

    def wait(self, k: int) -> bool:
        """Wait for frame ``k`` (0-based); False when the wait was abandoned."""
        now = self._clock()
        if self._start is None:
            self._start = now
        left = self._start + k * self.period - now
        return not (left > 0 and self._sleep(left))


class CreditWindow:
    """At most ``window`` frames published beyond the last one answered.

    Parameters
    ----------
    window : int
        Frames in flight, >= 1.
    timeout : float
        Seconds to wait for an answer before going on without it.
    clock : callable
        Seconds on a monotonic clock, which the timeout is counted on.
    """

    def __init__(self, window: int = 2, timeout: float = 1.0,
                 clock: Callable[[], float] = time.monotonic) -> None:
        if window < 1:
            raise ValueError(f"window must be >= 1, got {window}")
        self.window = window
        self.timeout = timeout
        self.answered = -1
        self.timeouts = 0
        self._clock = clock
        self._cond = threading.Condition()
        self._stopped = False

    def answer(self, frame_index: int) -> None:
        """Record that ``frame_index`` (and every frame before it) was answered."""
        with self._cond:
            if frame_index > self.answered:
                self.answered = frame_index
                self._cond.notify_all()

    def reset(self, answered: int = -1) -> None:
        """Forget the answers (a new run of the source)."""
        with self._cond:
            self.answered = answered

    def stop(self) -> None:
        """Release a waiting :meth:`wait`."""
        with self._cond:
            self._stopped = True
            self._cond.notify_all()

    def wait(self, k: int) -> bool:
        """Wait until frame ``k`` may be published; False when stopped.

        On a timeout the missing answers are given up on (counted in
        :attr:`timeouts`) and the window moves on.
        """
        deadline = self._clock() + self.timeout
        with self._cond:
            while k - self.answered > self.window and not self._stopped:
                left = deadline - self._clock()
                if left <= 0:
                    self.timeouts += 1
                    self.answered = k - self.window
                    break
                self._cond.wait(left)
            return not self._stopped
