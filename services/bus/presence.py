"""Presence: which services of the stream are alive, from their liveliness tokens and, in a
run with keys, their signed statuses.

A liveliness token says nothing of who declared it: in a run with keys, a service whose key
this process holds counts as alive only once a status it signed says it is up (any state
but ``starting``, ``stopped`` or ``failed``), so that another program cannot make the
source start before the run's services are there. A mixin of
:class:`services.bus.session.Service`.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterable
from typing import Any

from proto.auth import Keyring
from proto.keys import alive_wildcard, status_key
from services.bus.inbox import Screen
from services.bus.trust import Replays

DOWN = ("starting", "stopped", "failed")
"""States of a status that do not vouch for a service being up."""


class Presence:
    """Follows the stream's liveliness tokens with a subscriber that has history, and the
    statuses of the services whose keys this process holds."""

    session: Any
    stream: str
    keyring: Keyring
    screen: Screen
    _declared: list[Any]
    _alive: set[str]
    _vouched: set[str]
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
        """Follow which services of the stream hold liveliness tokens (with history) and,
        with keys, which have said in a signed status that they are up."""
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
        if self.keyring:
            replays = Replays()

            def on_status(sample: Any) -> None:
                status = self.screen.check(sample.payload.to_bytes(), str(sample.key_expr),
                                           "status", replays)
                if status is not None:
                    with self._lock:
                        if status.state in DOWN:  # type: ignore[attr-defined]
                            self._vouched.discard(status.service)  # type: ignore[attr-defined]
                        else:
                            self._vouched.add(status.service)  # type: ignore[attr-defined]

            for name in self.keyring.public:  # the statuses it can check, no other
                sub = self.session.declare_subscriber(status_key(self.stream, name),
                                                      zenoh.handlers.Callback(on_status))
                self._declared.append(sub)
        self._watching = True

    def alive(self) -> set[str]:
        """Services of the stream alive now (after :meth:`watch_presence`): holding a token
        and, for those whose key this process holds, up by their last signed status."""
        with self._lock:
            return {name for name in self._alive
                    if name not in self.keyring.public or name in self._vouched}

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
