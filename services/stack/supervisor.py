"""Service processes: started with the spawn method, restarted when they die, stopped together.

Every service runs in its own process, started with
``multiprocessing.get_context("spawn")``: a forked child of a process holding
a Zenoh session or a GL context hangs or publishes nothing. A child runs
:func:`service_entry`, which imports the service module and calls its
``main(argv)``.

:class:`Supervisor` restarts a service that dies (non-zero exit or a signal)
after a back-off that doubles from ``backoff`` up to ``max_backoff`` seconds,
at most ``max_restarts`` times; the restarted process finds its restart count
in ``AAMTRACK_RESTARTS`` and reports it in its status. A service that exits
with code 0 has finished and stays down. Every service dies with the
launcher: its parent's pid is in ``AAMTRACK_PARENT_PID`` and it asks the
kernel for SIGTERM when its parent dies (:mod:`services.bus.process`).
"""

from __future__ import annotations

import contextlib
import importlib
import logging
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from services.bus.process import ENV_PARENT, ENV_RESTARTS, die_with_parent

log = logging.getLogger("aamtrack.launcher")


def service_entry(module: str, argv: Sequence[str], nice: int = 0) -> None:
    """Body of a service process: die with the launcher, lower its priority by ``nice``,
    run ``module.main(argv)`` and exit with its code."""
    die_with_parent()
    if nice:
        os.nice(nice)
    code = importlib.import_module(module).main(list(argv))
    sys.exit(int(code or 0))


@contextlib.contextmanager
def environment(env: Mapping[str, str]) -> Iterator[None]:
    """Set ``env`` in ``os.environ`` for the duration, then restore it.

    A spawned child inherits the environment at ``start()`` and imports numpy
    while unpickling its target, before any code of ours runs in it: variables
    such as ``OMP_NUM_THREADS`` must already be in the environment it inherits.
    """
    saved = {k: os.environ.get(k) for k in env}
    os.environ.update(env)
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


@contextlib.contextmanager
def interrupts_ignored_by_children() -> Iterator[None]:
    """Start children that ignore SIGINT until they install their own stop handlers.

    A terminal's Ctrl-C reaches the whole process group; a service still
    importing its modules would die of it with a ``KeyboardInterrupt``
    traceback. A child inherits an ignored SIGINT across exec (a handler it
    would not), and stops on it once :class:`services.bus.process.StopWatch`
    is installed. SIGINT stays blocked here meanwhile, so a Ctrl-C meant for
    the launcher is delivered after, not lost (Linux never discards a blocked
    signal, whatever its disposition); the child may inherit the block, which
    ``StopWatch.start`` lifts.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


@dataclass
class ServiceSpec:
    """How to run one service.

    Parameters
    ----------
    name : str
        Service name (a key chunk), also the process name.
    module : str
        Module with ``main(argv)``.
    argv : list of str
        Its arguments.
    restart : bool
        Restart it when it dies.
    nice : int
        Niceness added to the process: best-effort stages (overlays, logging)
        yield the CPU to the tracking path.
    """

    name: str
    module: str
    argv: list[str] = field(default_factory=list)
    restart: bool = True
    nice: int = 0


@dataclass
class _Managed:
    spec: ServiceSpec
    process: Any = None
    restarts: int = 0
    restart_at: float | None = None
    exitcode: int | None = None
    gave_up: bool = False


class Supervisor:
    """Start, watch, restart and stop service processes.

    Parameters
    ----------
    specs : sequence of ServiceSpec
        Started in order.
    env : mapping
        Extra environment for every process (set when it starts, so that it
        applies before the child's first import).
    max_restarts : int
        Restarts per service before giving up on it.
    backoff, max_backoff : float
        First and largest wait before a restart, seconds.
    """

    def __init__(
        self, specs: Sequence[ServiceSpec], env: Mapping[str, str] | None = None,
        max_restarts: int = 5, backoff: float = 0.5, max_backoff: float = 8.0,
    ) -> None:
        self._ctx = multiprocessing.get_context("spawn")
        self._env = dict(env or {})
        self._managed = {s.name: _Managed(s) for s in specs}
        self.max_restarts = max_restarts
        self.backoff = backoff
        self.max_backoff = max_backoff
        self.events: list[str] = []

    def start(self, names: Sequence[str] | None = None) -> None:
        """Start the named services (all by default)."""
        for name in names if names is not None else list(self._managed):
            self._start(self._managed[name])

    def _start(self, m: _Managed) -> None:
        env = {**self._env, ENV_RESTARTS: str(m.restarts), ENV_PARENT: str(os.getpid())}
        m.process = self._ctx.Process(
            target=service_entry, args=(m.spec.module, m.spec.argv, m.spec.nice),
            name=m.spec.name,
        )
        with environment(env), interrupts_ignored_by_children():
            m.process.start()
        m.exitcode, m.restart_at = None, None
        log.debug("started %s (pid %s)", m.spec.name, m.process.pid)

    def pid(self, name: str) -> int | None:
        """Process id of a running service."""
        p = self._managed[name].process
        return p.pid if p is not None and p.is_alive() else None

    def alive(self, name: str) -> bool:
        return self.pid(name) is not None

    def exitcode(self, name: str) -> int | None:
        """Exit code of a service that has stopped (negative: killed by that signal)."""
        return self._managed[name].exitcode

    def restarts(self, name: str) -> int:
        return self._managed[name].restarts

    def failed(self) -> list[str]:
        """Services that died and were not (or no longer) restarted."""
        return [n for n, m in self._managed.items()
                if m.gave_up or (m.exitcode not in (None, 0) and not m.spec.restart)]

    def check(self) -> None:
        """Notice deaths and restart services whose back-off has passed."""
        now = time.monotonic()
        for m in self._managed.values():
            p = m.process
            if p is None:
                continue
            if m.exitcode is None and not p.is_alive():
                p.join(0)
                m.exitcode = p.exitcode
                self._on_exit(m, now)
            elif m.restart_at is not None and now >= m.restart_at:
                m.restarts += 1
                self._note(f"restarting {m.spec.name} (restart {m.restarts})")
                self._start(m)

    def _on_exit(self, m: _Managed, now: float) -> None:
        code = m.exitcode
        if code == 0:
            log.debug("%s finished", m.spec.name)
            return
        how = f"signal {signal.Signals(-code).name}" if code and code < 0 else f"exit {code}"
        if not m.spec.restart:
            self._note(f"{m.spec.name} stopped ({how})")
        elif m.restarts >= self.max_restarts:
            m.gave_up = True
            self._note(f"{m.spec.name} died ({how}); gave up after {m.restarts} restarts")
        else:
            delay = min(self.backoff * 2**m.restarts, self.max_backoff)
            m.restart_at = now + delay
            self._note(f"{m.spec.name} died ({how}); restarting in {delay:g} s")

    def _note(self, text: str) -> None:
        self.events.append(text)
        log.warning("%s", text)

    def stop(self, timeout: float = 8.0) -> dict[str, int | None]:
        """SIGTERM every running service, wait up to ``timeout`` s, SIGKILL what remains.

        Returns each service's exit code (``None`` if never started).
        """
        running = [m for m in self._managed.values()
                   if m.process is not None and m.process.pid is not None]
        for m in reversed(running):
            m.restart_at = None
            if m.process.is_alive():
                m.process.terminate()
        deadline = time.monotonic() + timeout
        for m in running:
            m.process.join(max(0.0, deadline - time.monotonic()))
            if m.process.is_alive():
                log.error("%s did not stop within %g s: killing it", m.spec.name, timeout)
                m.process.kill()
                m.process.join(2.0)
            m.exitcode = m.process.exitcode
        return {n: m.exitcode for n, m in self._managed.items()}
