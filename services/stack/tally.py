"""Counting a run's answers per frame in bounded memory, however long the run.

:class:`Tally` counts distinct frame indices, remembering only the latest
:data:`WINDOW`; :class:`Pairs` matches each fit with a face to its pose the same way. Both
can be *closed* up to a frame (a service restarted there): an answer that comes later for
an earlier frame is late, counted apart, never as an answer.
"""

from __future__ import annotations

import collections

WINDOW = 4096
"""Frames remembered: far more than results arrive out of order by."""


class Tally:
    """Distinct frame indices counted once each."""

    def __init__(self, window: int = WINDOW) -> None:
        self.window = window
        self.count = 0
        self.late = 0
        """Answers that came for a frame at or below :attr:`floor`."""
        self.floor = -1
        """Every index at or below it is done with: closed, or older than the window."""
        self.highest = -1
        self._recent: set[int] = set()
        self._order: collections.deque[int] = collections.deque()

    def __len__(self) -> int:
        return self.count

    def __contains__(self, index: int) -> bool:
        return index in self._recent

    def add(self, index: int) -> bool:
        """Count ``index`` if it is new; whether it was."""
        if index in self._recent:
            return False
        if index <= self.floor:
            self.late += 1
            return False
        self._recent.add(index)
        self._order.append(index)
        self.count += 1
        self.highest = max(self.highest, index)
        if len(self._order) > self.window:
            old = self._order.popleft()
            self._recent.discard(old)
            self.floor = max(self.floor, old)
        return True

    def close(self, upto: int) -> None:
        """No index at or below ``upto`` counts from now on (one counted already stays)."""
        self.floor = max(self.floor, upto)


class Pairs:
    """Fits with a face and their poses, matched by (frame index, face id)."""

    def __init__(self, window: int = WINDOW) -> None:
        self.window = window
        self.with_face = 0
        self.posed = 0
        self.late = 0
        self.closed = -1
        self._owed: collections.OrderedDict[tuple[int, int], None] = collections.OrderedDict()
        self._early: collections.OrderedDict[tuple[int, int], None] = (
            collections.OrderedDict())

    def fit(self, key: tuple[int, int]) -> None:
        """A fit with a face: owed a pose (unless its pose came first)."""
        self.with_face += 1
        if self._early.pop(key, 0) is None:
            self.posed += 1
            return
        self._owed[key] = None
        while len(self._owed) > self.window:  # its pose never came: it stays owed
            self._owed.popitem(last=False)

    def pose(self, key: tuple[int, int]) -> None:
        """A pose: the answer to its fit (or early, before it)."""
        if key[0] <= self.closed:
            self.late += 1
        elif self._owed.pop(key, 0) is None:
            self.posed += 1
        else:
            self._early[key] = None
            while len(self._early) > self.window:
                self._early.popitem(last=False)

    def close(self, upto: int) -> None:
        """No pose of a frame at or below ``upto`` answers its fit from now on."""
        self.closed = max(self.closed, upto)
