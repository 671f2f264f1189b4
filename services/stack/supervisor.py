"""Service processes: started afresh, restarted when they die, stopped together.

Every service runs in a new Python process (``python -m
services.stack.child MODULE NICE KEYFD ARGV...``: fork and exec at once, never a
bare fork, since a forked copy of a process holding a Zenoh session or a GL
context hangs or publishes nothing). The child imports the service module and
calls its ``main(argv)``. Its keys (:class:`proto.auth.Keyring`) are handed over once it
is non-dumpable and untraced, over a socket pair whose end it inherits as its file
``KEYFD`` (:mod:`services.bus.handover`): never in its environment or on its command line.
A process that cannot be given its keys safely stops the run (:class:`HandoverError`),
unless the supervisor is ``insecure``, which it then notes.

Each service gets a process group of its own, so that a terminal's Ctrl-C
reaches the launcher alone: a service still importing its modules cannot die
of it with a traceback, and the launcher stops every service itself, with
SIGTERM, in order.

:class:`Supervisor` restarts a service that dies (non-zero exit or a signal)
after a back-off that doubles from ``backoff`` up to ``max_backoff`` seconds,
at most ``max_restarts`` times; the restarted process finds its restart count
in ``AAMTRACK_RESTARTS`` and reports it in its status. A service that exits
with code 0 has finished and stays down. Every service dies with the
launcher: its parent's pid is in ``AAMTRACK_PARENT_PID`` and it asks the
kernel for SIGTERM when its parent dies (:mod:`services.bus.process`).
"""

from __future__ import annotations

import logging
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import services
from proto.auth import Keyring
from services.bus.handover import HandoverError, ProcessGone, give_keys, spawn_channel
from services.bus.process import ENV_PARENT, ENV_RESTARTS
from services.bus.trust import Floors

log = logging.getLogger("aamtrack.launcher")
ROOT = str(Path(services.__file__).resolve().parent.parent)
"""The folder holding the ``services`` package, put first on the children's path."""


def child_command(module: str, argv: Sequence[str], nice: int = 0, key_fd: int | None = None
                  ) -> list[str]:
    """The command line of a service process running ``module.main(argv)`` (its keys over
    the inherited socket ``key_fd``, when given)."""
    fd = "-" if key_fd is None else str(key_fd)
    return [sys.executable, "-m", "services.stack.child", module, str(nice), fd, *argv]


def child_environment(extra: Mapping[str, str]) -> dict[str, str]:
    """This process's environment with ``extra`` and the path to this checkout's packages."""
    env = {**os.environ, **extra}
    env["PYTHONPATH"] = os.pathsep.join(p for p in (ROOT, env.get("PYTHONPATH", "")) if p)
    return env


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
    keyring : Keyring, optional
        The keys handed to the process (:mod:`services.bus.handover`; none when empty).
    """

    name: str
    module: str
    argv: list[str] = field(default_factory=list)
    restart: bool = True
    nice: int = 0
    keyring: Keyring = field(default_factory=Keyring)


@dataclass
class _Managed:
    spec: ServiceSpec
    process: subprocess.Popen | None = None
    restarts: int = 0
    restart_at: float | None = None
    exitcode: int | None = None
    gave_up: bool = False
    refused: bool = False
    """Refused its keys and killed (:meth:`Supervisor._hand`)."""


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
    floors : callable, optional
        ``floors(name)``: the run's high-water marks handed to a restarted service.
    insecure : bool
        Hand a process its keys even when it is traced or dumpable (noted in
        :attr:`insecure_notes`); without it such a process stops the run.
    """

    def __init__(
        self, specs: Sequence[ServiceSpec], env: Mapping[str, str] | None = None,
        max_restarts: int = 5, backoff: float = 0.5, max_backoff: float = 8.0,
        floors: Callable[[str], Floors] | None = None, insecure: bool = False,
    ) -> None:
        self._env = dict(env or {})
        self._managed = {s.name: _Managed(s) for s in specs}
        self.max_restarts = max_restarts
        self.backoff = backoff
        self.max_backoff = max_backoff
        self.floors = floors
        self.insecure = insecure
        self.insecure_notes: list[str] = []
        """Each process handed its keys though it could not keep them safe (insecure)."""
        self.events: list[str] = []

    def start(self, names: Sequence[str] | None = None) -> None:
        """Start the named services (all by default): every process first, then each one's
        keys as it asks for them.

        Raises
        ------
        HandoverError
            When a process cannot be given its keys safely (it is stopped).
        """
        chosen = [self._managed[n] for n in (names if names is not None else self._managed)]
        for m, channel in [(m, self._spawn(m)) for m in chosen]:
            self._hand(m, channel)

    def _start(self, m: _Managed) -> None:
        self._hand(m, self._spawn(m))

    def _spawn(self, m: _Managed) -> socket.socket | None:
        """Start ``m``'s process; the launcher's end of its key channel (None: no keys)."""
        env = {**self._env, ENV_RESTARTS: str(m.restarts), ENV_PARENT: str(os.getpid())}
        channel, service_end = spawn_channel() if m.spec.keyring else (None, None)
        fd = None if service_end is None else service_end.fileno()
        try:
            m.process = subprocess.Popen(
                child_command(m.spec.module, m.spec.argv, m.spec.nice, fd),
                env=child_environment(env), stdin=subprocess.DEVNULL, process_group=0,
                pass_fds=() if fd is None else (fd,),
            )
        except BaseException:
            if channel is not None:
                channel.close()
            raise
        finally:
            if service_end is not None:
                service_end.close()
        m.exitcode, m.restart_at = None, None
        log.debug("started %s (pid %s)", m.spec.name, m.process.pid)
        return channel

    def _hand(self, m: _Managed, channel: socket.socket | None) -> None:
        """Give ``m``'s process its keys (and, restarted, the run's floors) once it is safe."""
        if channel is None or m.process is None:
            return
        floors = self.floors(m.spec.name) if m.restarts and self.floors else None
        process = m.process
        with channel:
            try:
                handed = give_keys(channel, process.pid, m.spec.name, m.spec.keyring,
                                   floors, self.insecure,
                                   alive=lambda: process.poll() is None)
            except ProcessGone:  # died on its way up: restarted as any death is
                return
            except HandoverError:
                m.gave_up = m.refused = True
                m.process.kill()  # a tracer may keep it unreaped: never waited for long
                raise
        if handed.problem:
            self.insecure_notes.append(handed.problem)
            self._note(f"{handed.problem}: handed its key anyway (--insecure)")

    def pid(self, name: str) -> int | None:
        """Process id of a running service."""
        p = self._managed[name].process
        return p.pid if p is not None and p.poll() is None else None

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
            if m.exitcode is None and p.poll() is not None:
                m.exitcode = p.returncode
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
        running = [(m, m.process) for m in self._managed.values() if m.process is not None]
        for m, p in reversed(running):
            m.restart_at = None
            if p.poll() is None:
                p.terminate()
        deadline = time.monotonic() + timeout
        for m, p in running:
            try:
                p.wait(0.5 if m.refused else max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                if m.refused:  # killed already, and its tracer holds it: nothing to say
                    continue
                log.error("%s did not stop within %g s: killing it", m.spec.name, timeout)
                p.kill()
                try:
                    p.wait(2.0)
                except subprocess.TimeoutExpired:  # killed, but its tracer has not let go
                    log.error("%s (pid %s) was killed but cannot be reaped (traced?)",
                              m.spec.name, p.pid)
            m.exitcode = p.returncode
        return {n: m.exitcode for n, m in self._managed.items()}
