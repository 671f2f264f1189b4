"""Presence: which services of the stream are alive, from their liveliness tokens.

A mixin of :class:`services.bus.session.Service`.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterable
from typing import Any

from proto.keys import alive_wildcard


class Presence:
    """Follows the stream's liveliness tokens with a subscriber that has history."""

    session: Any
    stream: str
    _declared: list[Any]
    _alive: set[str]
    _watching: bool
    _lock: threading.Lock

    @property
    def stopping(self) -> bool:
        raise NotImplementedError

    def wait(self, seconds: float) -> bool:
        raise NotImplementedError

    def peers(self) -> int:
        """Zenoh peers and routers this session is connected to now."""
        info = self.session.info
        return len(list(info.peers_zid())) + len(list(info.routers_zid()))

    def watch_presence(self) -> None:
        """Follow which services of the stream hold liveliness tokens (with history)."""
        import zenoh

        def on_change(sample: Any) -> None:
            name = str(sample.key_expr).rsplit("/", 1)[-1]
            with self._lock:
                if sample.kind == zenoh.SampleKind.DELETE:
                    self._alive.discard(name)
                else:
                    self._alive.add(name)

        sub = self.session.liveliness().declare_subscriber(
            alive_wildcard(self.stream), zenoh.handlers.Callback(on_change), history=True)
        self._declared.append(sub)
        self._watching = True

    def alive(self) -> set[str]:
        """Services of the stream alive now (after :meth:`watch_presence`)."""
        with self._lock:
            return set(self._alive)

    def wait_for_alive(self, services: Iterable[str], timeout: float) -> list[str]:
        """Wait until ``services`` of this stream are alive; return those missing."""
        if not self._watching:
            self.watch_presence()
        wanted = set(services)
        deadline = time.monotonic() + timeout
        while not self.stopping:
            missing = wanted - self.alive()
            if not missing or time.monotonic() >= deadline:
                return sorted(missing)
            self.wait(0.02)
        return sorted(wanted - self.alive())
