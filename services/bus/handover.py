"""Handing a service process its keys: only once it is non-dumpable and untraced, over a
channel no other process can have opened.

The launcher starts each service with one end of a Unix socket pair (a socket cannot be
opened through ``/proc/<pid>/fd``, as a pipe can). The service, as its first act, makes
itself non-dumpable (:func:`services.bus.trust.harden`); only then does it make a *second*
socket pair and send one end of it, with a report of its state, over the first
(:func:`receive_keys`). Another process could have duplicated the first socket in the
instant between ``exec`` and the hardening (``pidfd_getfd``); it can never hold the second,
made once nobody else can reach the process. The launcher (:func:`give_keys`) checks that the
end it got was made by that very process (``SO_PEERCRED``), that the process says it is
non-dumpable and that nobody traces it (``TracerPid`` 0, read by both sides), and only then
writes the keys, and a restarted service's floors (:data:`services.bus.trust.Floors`), into
the second pair. Otherwise it writes a refusal, and the run does not go on (unless
``--insecure``, which the summary records).
"""

from __future__ import annotations

import array
import json
import os
import socket
import struct
import time
from collections.abc import Callable
from dataclasses import dataclass

from proto.auth import Keyring
from services.bus.trust import Floors, dumpable, tracer_of

HANDOVER_TIMEOUT = 60.0
"""Seconds the launcher waits for a started service's report (an interpreter starting on a
loaded machine)."""
POLL_S = 0.2
"""Seconds between two looks at whether the process still lives, while it is waited for."""
MAX_REPORT = 4096
MAX_KEYS = 1 << 20
REFUSED = b"refused"
_UCRED = struct.Struct("3i")


class HandoverError(RuntimeError):
    """A service could not be given its keys safely: the run must not go on."""


class ProcessGone(RuntimeError):
    """The service's process ended before it asked for its keys (a death, not a threat: it
    is restarted as any other)."""


@dataclass(frozen=True)
class Handed:
    """What :func:`give_keys` did: ``problem`` is why the process may not be safe (empty:
    none), and the keys went only if it is empty or the run is insecure."""

    problem: str = ""


def _report() -> bytes:
    return json.dumps({"dumpable": dumpable(), "tracer": tracer_of()}).encode()


def receive_keys(fd: int) -> tuple[Keyring, Floors] | None:
    """In a service process, once hardened: report over the inherited socket ``fd``, with a
    fresh socket pair's end, and read the keys from the fresh pair.

    Returns None when the launcher refused (it says why; the process must exit 2).
    """
    inherited = socket.socket(fileno=fd)
    mine, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_STREAM)
    with inherited, mine:
        fds = array.array("i", [theirs.fileno()])
        inherited.sendmsg([_report()], [(socket.SOL_SOCKET, socket.SCM_RIGHTS, fds)])
        theirs.close()
        mine.shutdown(socket.SHUT_WR)
        data = _read_all(mine, MAX_KEYS)
    if not data or data.startswith(REFUSED):
        return None
    obj = json.loads(data)
    floors = {(p, k): int(v) for p, k, v in obj.get("floors", [])}
    return Keyring.from_bytes(obj["keyring"].encode()), floors


def _read_all(sock: socket.socket, limit: int) -> bytes:
    parts, size = [], 0
    while chunk := sock.recv(65536):
        parts.append(chunk)
        size += len(chunk)
        if size > limit:
            raise HandoverError("the key channel carries more than a keyring")
    return b"".join(parts)


def _peer_pid(sock: socket.socket) -> int:
    pid, _uid, _gid = _UCRED.unpack(sock.getsockopt(socket.SOL_SOCKET, socket.SO_PEERCRED,
                                                    _UCRED.size))
    return pid


def _request(launcher_end: socket.socket, name: str, timeout: float,
             alive: Callable[[], bool]) -> tuple[bytes, list]:
    """The service's key request, waited for while its process lives (another process may
    hold its end of the channel open after it died)."""
    deadline = time.monotonic() + timeout
    while True:
        launcher_end.settimeout(max(0.01, min(POLL_S, deadline - time.monotonic())))
        try:
            data, ancillary, _flags, _addr = launcher_end.recvmsg(
                MAX_REPORT, socket.CMSG_SPACE(4 * array.array("i").itemsize))
            return data, ancillary
        except TimeoutError:
            if not alive():
                raise ProcessGone(f"{name} ended before it asked for its keys") from None
            if time.monotonic() >= deadline:
                raise HandoverError(f"{name} never asked for its keys within {timeout:g} s"
                                    ) from None


def _fresh_channel(launcher_end: socket.socket, name: str, timeout: float,
                   alive: Callable[[], bool]) -> tuple[socket.socket, dict]:
    """The fresh socket the service sent, and its report."""
    data, ancillary = _request(launcher_end, name, timeout, alive)
    fds = array.array("i")
    for level, kind, payload in ancillary:
        if level == socket.SOL_SOCKET and kind == socket.SCM_RIGHTS:
            fds.frombytes(payload[:len(payload) - len(payload) % fds.itemsize])
    sockets = [socket.socket(fileno=fd) for fd in fds]
    if not data or len(sockets) != 1:
        for s in sockets:
            s.close()
        if not data:
            raise ProcessGone(f"{name} ended before it asked for its keys")
        raise HandoverError(f"{name}: its key channel carried no fresh socket: refused")
    try:
        report = json.loads(data)
    except ValueError:
        report = {}
    return sockets[0], report if isinstance(report, dict) else {}


def give_keys(launcher_end: socket.socket, pid: int, name: str, keyring: Keyring,
              floors: Floors | None = None, insecure: bool = False,
              timeout: float = HANDOVER_TIMEOUT, alive: Callable[[], bool] = lambda: True
              ) -> Handed:
    """In the launcher: wait for service ``name`` (process ``pid``) to report over
    ``launcher_end``, check it, and hand it ``keyring`` (and ``floors``) over the fresh
    channel it sent.

    Raises
    ------
    HandoverError
        When the process cannot be given its keys safely (and the run is not insecure), or
        its channel was tampered with (never insecure: the keys would go to another
        process).
    ProcessGone
        When the process ended (``alive()`` false) before it asked.
    """
    channel, report = _fresh_channel(launcher_end, name, timeout, alive)
    with channel:
        maker = _peer_pid(channel)
        if maker != pid:
            channel.sendall(REFUSED)
            raise HandoverError(f"{name} (pid {pid}): its key channel was made by pid "
                                f"{maker}: another process reached it; refused")
        tracer = tracer_of(pid)
        problems = []
        if report.get("dumpable") is not False:
            problems.append("it could not make itself non-dumpable")
        if tracer or report.get("tracer") != 0:
            problems.append(f"it is traced (by pid {tracer if tracer else report.get('tracer')})")
        problem = f"{name} (pid {pid}): " + " and ".join(problems) if problems else ""
        if problem and not insecure:
            channel.sendall(REFUSED)
            raise HandoverError(f"{problem}: its key was not handed over (--insecure runs "
                                "anyway)")
        channel.sendall(json.dumps({
            "keyring": keyring.to_bytes().decode(),
            "floors": [[p, k, v] for (p, k), v in (floors or {}).items()]}).encode())
    return Handed(problem)


def spawn_channel() -> tuple[socket.socket, socket.socket]:
    """The socket pair a service is started with: (the launcher's end, the service's end,
    to pass to it and close in the launcher once it started)."""
    launcher_end, service_end = socket.socketpair(socket.AF_UNIX, socket.SOCK_STREAM)
    os.set_inheritable(service_end.fileno(), True)
    return launcher_end, service_end
