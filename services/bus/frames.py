"""Frames kept for the results still to come about them.

A stage that works on a result with its frame (the glasses renderer on a pose, the
expression service on a fit) receives the frames as they are published and the results
later, from another producer. :class:`FrameStore` keeps each frame from its arrival until
no result for it can come any more: a result for a later frame has been handled (results
come in frame order, :meth:`FrameStore.forget_before`), or the store's bounds push it out,
oldest first: at most ``count`` frames and ``max_bytes`` of pixels, each pushed-out frame
counted (:attr:`FrameStore.pushed_out`). With the source's credit window
(:mod:`services.source.pacing`) no more frames are in flight than the slowest stage takes,
so the bounds are a guard, not the rule.
"""

from __future__ import annotations

import collections
from collections.abc import Callable
from dataclasses import replace

from services.bus.inbox import Received, Recent, Screen

FRAMES_KEPT = 32
"""Frames a store keeps at most (more than any stage's backlog under the credit window)."""
MAX_BYTES = 64 * 2**20
"""Bytes of pixels a store keeps at most: 97 frames of 640 x 360, 24 of 1280 x 720."""


def pixels_only(got: Received) -> Received:
    """A frame as a store keeps it: its message (header and pixels), not its payload."""
    return replace(got, payload=b"")


class FrameStore(Recent):
    """The frames of a stream by ``(run id, frame index)``, kept until :meth:`forget_before`
    says no result can come for them, at most ``count`` of them and ``max_bytes`` of pixels
    (the oldest pushed out first, counted).

    ``compact(got)`` is what is kept of each frame (by default its message without its
    payload); :meth:`take` is :meth:`Recent.take`.
    """

    def __init__(self, screen: Screen, key: str, count: int = FRAMES_KEPT,
                 max_bytes: int = MAX_BYTES,
                 compact: Callable[[Received], Received] | None = pixels_only) -> None:
        super().__init__(screen, key, "frame", count, compact)
        self.max_bytes = max_bytes
        self.pushed_out = 0
        """Frames pushed out by the bounds before a result could take them."""
        self.forgotten = 0
        """Frames forgotten because a result for a later frame came: none will come."""
        self._sizes: collections.OrderedDict[tuple[str, int], int] = collections.OrderedDict()
        self._bytes = 0

    @property
    def kept_bytes(self) -> int:
        with self._cond:
            return self._bytes

    def _keep(self, got: Received) -> None:
        h = got.message.header
        key = (h.run_id, h.frame_index)
        size = _size(got)
        self._drop(key)
        self._items[key] = got
        self._sizes[key] = size
        self._bytes += size
        self._newest = (h.run_id, max(h.frame_index, self._newest[1])
                        if h.run_id == self._newest[0] else h.frame_index)
        while len(self._items) > 1 and (len(self._items) > self.size
                                        or self._bytes > self.max_bytes):
            oldest = next(iter(self._items))
            self._drop(oldest)
            self.pushed_out += 1

    def _drop(self, key: tuple[str, int]) -> None:
        if self._items.pop(key, None) is not None:
            self._bytes -= self._sizes.pop(key)

    def take(self, run_id: str, frame_index: int, timeout: float = 0.0, keep: bool = False
             ) -> Received | None:
        got = super().take(run_id, frame_index, timeout, keep=True)
        if got is not None and not keep:
            with self._cond:
                self._drop((run_id, frame_index))
        return got

    def forget_before(self, run_id: str, frame_index: int) -> int:
        """Forget the frames of ``run_id`` before ``frame_index`` and those of other runs:
        a result for ``frame_index`` has come, so none will come for them. How many."""
        with self._cond:
            old = [k for k in self._items if k[0] != run_id or k[1] < frame_index]
            for key in old:
                self._drop(key)
            self.forgotten += len(old)
            return len(old)

    def __len__(self) -> int:
        with self._cond:
            return len(self._items)


def _size(got: Received) -> int:
    image = getattr(got.message, "image", b"")
    return len(got.payload) + (image.nbytes if hasattr(image, "nbytes") else len(image))
