"""Images written once into Zenoh shared memory; over the network where it cannot be.

A frame or overlay is the largest message on the bus (691 KB at 640 x 360). Its producer
writes it once into a buffer of its own Zenoh shared-memory pool (:class:`SharedImages`,
room for a few images, sized by the first):
the payload's small head, then the pixels, copied from where they were decoded or rendered
(:func:`proto.codec.encode_parts`), hashed there for the signature. Subscribers on the host
receive that buffer itself; across hosts Zenoh sends the same bytes over the network.

Where shared memory is missing, full (its readers still hold every buffer of the pool) or
too small for the message (one larger than the pool: a JPEG's size varies), the message
goes over the network as any other: the run goes on with one warning line per reason, and
each such image is counted (:meth:`SharedImages.line`, in the producer's status and the
run's summary). A pool full for a moment is a loaded machine's readers lagging, not a
fault: said once as information, and warned of only when it stays full for
:data:`FULL_POOLS` pools' worth of images in a row (a reader holding its buffers). The
producer never waits for a buffer: a reader that holds buffers too long costs it shared
memory, never time. Zenoh removes a pool's segment when its process ends, and the segments
of killed processes when the next pool is made (its orphaned-segment clean-up: no process
has them open).
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the options modules import this one: --help loads no msgpack nor numpy
    from proto.codec import Buffer

POOL_IMAGES = 8
"""Images a pool holds by default. Each is written where one a few images back lay, still in
the CPU's cache: a copy of a 640 x 360 frame into a pool of 8 takes 0.04 ms, into one of 48
(32 MiB) 0.2 ms (``bench/bench_frame_transport.py``). Readers copy a frame as it arrives, so
a few are in use at a time; a reader behind by more sends the next ones over the network."""
SLACK = 4096
"""Bytes of the pool per image beyond the image (the allocator's own)."""
FULL_POOLS = 3
"""Pools' worth of images in a row that must find the pool full before a warning."""
REASONS = ("unavailable", "full", "too small")
"""Why an image went over the network, as counted."""


class SharedImages:
    """A producer's pool of shared memory for its image messages, made with the first: room
    for ``images`` of its size.

    Parameters
    ----------
    images : int
        Images the pool holds; 0: no shared memory (every image over the network, not
        counted as a fall-back: it was asked for).
    log : logging.Logger
    available : bool
        False where the session found no shared memory (and said so): every image goes
        over the network, counted as ``unavailable`` without a second warning.
    """

    def __init__(self, images: int, log: logging.Logger, available: bool = True) -> None:
        self.images = images
        self.pool_bytes = 0
        """Size of the pool once made (0 before the first image)."""
        self.log = log
        self.shared = 0
        """Images written into shared memory."""
        self.network: Counter[str] = Counter()
        """Images sent over the network, by reason (:data:`REASONS`, or ``off``)."""
        self.copied = 0
        """Images whose pixels were not in a ``bytes`` or ``bytearray``: copied once more."""
        self._provider: Any = None
        self._policy: Any = None
        self._unavailable = images <= 0 or not available
        self._full_in_a_row = 0

    def payload(self, parts: Sequence[Buffer]) -> Any:
        """What to put for a payload made of ``parts``: a shared-memory buffer holding them
        (``zenoh.ZBytes``), else their bytes."""
        size = sum(memoryview(p).nbytes for p in parts)
        buffer = self._alloc(size)
        if buffer is None:
            return b"".join(parts)
        start = 0
        for part in parts:
            if not isinstance(part, bytes | bytearray):
                part = bytes(part)  # the buffer takes only these (zenoh-python's abi3 wheel)
                self.copied += 1
            buffer[start:start + len(part)] = part
            start += len(part)
        self.shared += 1
        import zenoh

        return zenoh.ZBytes(buffer)

    def _alloc(self, size: int) -> Any:
        """A buffer of ``size`` bytes of the pool, or None (counted, warned once a reason)."""
        if self._unavailable:
            self._over_network("off" if self.images <= 0 else "unavailable")
            return None
        if self._provider is None and not self._open(self.images * (size + SLACK)):
            return None
        if size > self.pool_bytes - SLACK:
            self._over_network("too small", f"the shared-memory pool of "
                               f"{_size(self.pool_bytes)} cannot hold an image message of "
                               f"{_size(size)}")
            return None
        import zenoh

        try:
            buffer = self._provider.alloc(size, self._policy)
        except zenoh.ZError as exc:
            self._full(str(exc))
            return None
        self._full_in_a_row = 0
        return buffer

    def _full(self, why: str) -> None:
        if not self.network["full"]:
            self.log.info("the shared-memory pool is full (%s): its readers still hold every "
                          "buffer; images go over the network until one is free (counted)", why)
        self._full_in_a_row += 1
        if self._full_in_a_row == FULL_POOLS * self.images:
            self.log.warning("the shared-memory pool has been full for %d images in a row: a "
                             "reader holds its buffers; images go over the network instead "
                             "(counted)", self._full_in_a_row)
        self.network["full"] += 1

    def _open(self, pool_bytes: int) -> bool:
        try:
            from zenoh import shm

            self._provider = shm.ShmProvider.default_backend(pool_bytes)
            self.pool_bytes = pool_bytes
            self._policy = shm.GarbageCollect()
        except Exception as exc:  # no shm module, no /dev/shm, none left: zenoh.ZError or others
            self._unavailable = True
            self._over_network("unavailable", f"no shared memory ({type(exc).__name__}: {exc})")
            return False
        return True

    def _over_network(self, reason: str, why: str = "") -> None:
        if why and not self.network[reason]:
            self.log.warning("%s: images go over the network instead (counted)", why)
        self.network[reason] += 1

    @property
    def fallbacks(self) -> int:
        """Images that went over the network though shared memory was asked for."""
        return sum(n for reason, n in self.network.items() if reason != "off")

    def line(self) -> str:
        """``"images in shared memory 280, over the network 8 (full 8)"``"""
        sent = sum(self.network.values())
        reasons = ", ".join(f"{r} {n}" for r, n in self.network.most_common())
        return (f"images in shared memory {self.shared}, over the network {sent}"
                + (f" ({reasons})" if sent else ""))


def _size(n: int) -> str:
    return f"{n / 2**20:.1f} MiB" if n >= 2**20 else f"{n / 2**10:.0f} KiB"
