"""Service processes: started afresh, restarted when they die, stopped together.

Every service runs in a new Python process (``python -m
services.stack.child MODULE NICE KEYFD ARGV...``: fork and exec at once, never a
bare fork, since a forked copy of a process holding a Zenoh session or a GL
context hangs or publishes nothing). The child imports the service module and
calls its ``main(argv)``. Its keys (:class:`proto.auth.Keyring`) come through a pipe
whose read end is its file ``KEYFD``, written and closed by the launcher as the process
starts: never in its environment or on its command line.

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
import subprocess
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import services
from proto.auth import Keyring
from services.bus.process import ENV_PARENT, ENV_RESTARTS

log = logging.getLogger("aamtrack.launcher")
ROOT = str(Path(services.__file__).resolve().parent.parent)
"""The folder holding the ``services`` package, put first on the children's path."""


def child_command(module: str, argv: Sequence[str], nice: int = 0, key_fd: int | None = None
                  ) -> list[str]:
    """The command line of a service process running ``module.main(argv)`` (its keys in the
    inherited pipe ``key_fd``, when given)."""
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
        The keys handed to the process (through a pipe; none when empty).
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
        keys = m.spec.keyring.to_bytes() if m.spec.keyring else b""
        read_end, write_end = os.pipe() if keys else (None, None)
        try:
            m.process = subprocess.Popen(
                child_command(m.spec.module, m.spec.argv, m.spec.nice, read_end),
                env=child_environment(env), stdin=subprocess.DEVNULL, process_group=0,
                pass_fds=() if read_end is None else (read_end,),
            )
        except BaseException:
            if write_end is not None:
                os.close(write_end)
            raise
        finally:
            if read_end is not None:
                os.close(read_end)
        if write_end is not None:
            with os.fdopen(write_end, "wb") as pipe:  # a few hundred bytes: never blocks
                pipe.write(keys)
        m.exitcode, m.restart_at = None, None
        log.debug("started %s (pid %s)", m.spec.name, m.process.pid)

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
                p.wait(max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                log.error("%s did not stop within %g s: killing it", m.spec.name, timeout)
                p.kill()
                p.wait(2.0)
            m.exitcode = p.returncode
        return {n: m.exitcode for n, m in self._managed.items()}
