"""Setting up a service process: threads, logging, stop signals and dying with the launcher.

Signal handlers here only record the signal (an attribute assignment, which
cannot deadlock however signals nest); a watcher thread turns it into a stop
request. A process started by the launcher also stops when the launcher dies:
the kernel sends it SIGTERM (``PR_SET_PDEATHSIG``) and the watcher sees its
parent change, whichever comes first.
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import os
import signal
import threading
from collections.abc import Callable
from typing import Any

ENV_PARENT = "AAMTRACK_PARENT_PID"
"""Set by the launcher's supervisor: the process a service must die with."""
ENV_RESTARTS = "AAMTRACK_RESTARTS"
"""Set by the supervisor to the number of times it restarted the service."""
ENV_LOG_LEVEL = "AAMTRACK_LOG_LEVEL"
"""The level a service logs at (default INFO; ``--verbose``: DEBUG). The launcher sets
WARNING, so that a run prints its progress and summary, not each service's news."""
STOP_SIGNALS = (signal.SIGTERM, signal.SIGINT, signal.SIGHUP)
WATCH_PERIOD = 0.05
"""Seconds between two looks at the signal flag and the parent."""
PR_SET_PDEATHSIG = 1

_log = logging.getLogger("aamtrack.process")


def init_process(name: str, verbose: bool = False) -> logging.Logger:
    """Set up a service process: one compute thread, logging; return its logger.

    ``OMP_NUM_THREADS`` only takes effect before numpy's first import, so the
    launcher sets it in the environment of the processes it spawns as well.
    """
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    import cv2

    cv2.setNumThreads(1)
    root = logging.getLogger()
    level = os.environ.get(ENV_LOG_LEVEL, "INFO").upper()
    if not root.handlers:
        logging.basicConfig(
            level=logging.DEBUG if verbose else getattr(logging, level, logging.INFO),
            format=f"%(asctime)s {name}[%(process)d] %(levelname)s %(message)s",
        )
    elif verbose:
        root.setLevel(logging.DEBUG)
    import zenoh

    zenoh.init_log_from_env_or("error")
    return logging.getLogger(f"aamtrack.{name}")


def die_with_parent() -> None:
    """Ask the kernel for SIGTERM when the parent process dies (Linux; no-op elsewhere)."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)
    except (OSError, AttributeError) as exc:  # not Linux: the watcher still sees the parent go
        _log.debug("no parent-death signal: %s", exc)


def parent_pid() -> int | None:
    """The process this one must die with (from :data:`ENV_PARENT`), if any."""
    text = os.environ.get(ENV_PARENT, "")
    return int(text) if text.isdigit() else None


def release_memory() -> None:
    """Give the memory freed since the last call back to the system (glibc's
    ``malloc_trim``), so that a flood of messages does not leave a process at its
    high-water mark; no-op elsewhere."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None).malloc_trim(0)


class StopWatch:
    """Turns stop signals and the death of the parent into one call of ``on_stop(reason)``.

    Parameters
    ----------
    on_stop : callable
        Called once, from the watcher thread, with why the process must stop.
    handle_signals : bool
        Install handlers for SIGTERM, SIGINT and SIGHUP (main thread only).
    """

    def __init__(self, on_stop: Callable[[str], None], handle_signals: bool = True) -> None:
        self._on_stop = on_stop
        self._handle = handle_signals and threading.current_thread() is threading.main_thread()
        self._signalled = 0
        self._parent = parent_pid()
        self._old: dict[int, Any] = {}
        self._done = threading.Event()
        self._thread: threading.Thread | None = None

    def _record(self, signum: int, frame: Any) -> None:
        self._signalled = signum  # nothing else here: handlers may nest

    def start(self) -> None:
        if self._handle:
            for sig in STOP_SIGNALS:
                self._old[sig] = signal.signal(sig, self._record)
        self._thread = threading.Thread(target=self._watch, name="stop-watch", daemon=True)
        self._thread.start()

    def _reason(self) -> str:
        if self._signalled:
            return f"signal {signal.Signals(self._signalled).name}"
        if self._parent is not None and os.getppid() != self._parent:
            return f"the launcher (pid {self._parent}) is gone"
        return ""

    def _watch(self) -> None:
        while not self._done.wait(WATCH_PERIOD):
            reason = self._reason()
            if reason:
                self._on_stop(reason)
                return

    def close(self) -> None:
        """Stop watching and put the old signal handlers back (main thread)."""
        self._done.set()
        if self._handle and threading.current_thread() is threading.main_thread():
            for sig, handler in self._old.items():
                signal.signal(sig, handler)
        self._old.clear()
