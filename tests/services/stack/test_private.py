"""A default run is reachable by its own user only: its processes listen on Unix sockets in
a folder of mode 0700 and on no TCP port, and another OS user cannot connect to them."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path

import pytest

from services.bus.runtime import runtime_dir, socket_path
from services.stack.launcher import Stack, prepared
from services.stack.options import StackOptions

NOBODY = 65534
PROBE = r"""
import json, socket, sys
paths, ports = json.loads(sys.argv[1]), json.loads(sys.argv[2])
out = {}
for path in paths:
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        s.connect(path)
        out[path] = "connected"
    except OSError as exc:
        out[path] = type(exc).__name__
    finally:
        s.close()
for port in ports:
    try:
        socket.create_connection(("127.0.0.1", port), timeout=2).close()
        out[str(port)] = "connected"
    except OSError as exc:
        out[str(port)] = type(exc).__name__
print(json.dumps(out))
"""


def _tcp_listening_ports(pids: list[int]) -> set[int]:
    """TCP ports in LISTEN that any of ``pids`` holds (from /proc)."""
    inodes = set()
    for pid in pids:
        for fd in Path(f"/proc/{pid}/fd").iterdir():
            try:
                target = os.readlink(fd)
            except OSError:
                continue
            if target.startswith("socket:["):
                inodes.add(target[8:-1])
    ports = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in Path(table).read_text().splitlines()[1:]:
            cols = line.split()
            if cols[3] == "0A" and cols[9] in inodes:  # 0A: LISTEN
                ports.add(int(cols[1].rsplit(":", 1)[1], 16))
    return ports


def _probe(paths: list[str], ports: list[int], user: int | None) -> dict[str, str]:
    python = shutil.which("python3", path="/usr/bin:/bin") or "/usr/bin/python3"
    done = subprocess.run([python, "-c", PROBE, json.dumps(paths), json.dumps(ports)],
                          capture_output=True, text=True, timeout=30, user=user, cwd="/")
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


@pytest.mark.skipif(os.geteuid() != 0 or not Path("/usr/bin/python3").exists(),
                    reason="needs root to run a probe as another user, and /usr/bin/python3")
def test_another_user_cannot_reach_a_default_run(
    single_face: Path, stack_options: Callable[..., StackOptions],
) -> None:
    folder = runtime_dir()
    assert folder.stat().st_mode & 0o777 == 0o700 and folder.stat().st_uid == os.getuid()
    opts = prepared(stack_options(single_face, ar=False, pace="realtime", loop=2))
    with Stack(opts) as stack:
        launcher = socket_path(stack.endpoint)
        assert launcher is not None and launcher.parent == folder
        sockets: list[str] = []
        for _ in range(600):  # every service listening on its socket (at most a minute)
            sockets = sorted(str(p) for p in folder.glob(f"{stack.run_id}-*.sock"))
            if len(sockets) == len(stack.specs) or stack.service.wait(0.1):
                break
        assert launcher.exists() and len(sockets) == len(stack.specs), sockets
        pids = [os.getpid(), *(p for s in stack.specs
                               if (p := stack.supervisor.pid(s.name)) is not None)]
        ports = sorted(_tcp_listening_ports(pids))
        assert ports == [], f"the run listens on TCP ports {ports}"
        paths = [str(launcher), *sockets]
        mine = _probe(paths, [7447], None)
        theirs = _probe(paths, [7447], NOBODY)
        assert stack.wait() == "done"
    assert all(mine[p] == "connected" for p in paths), mine  # the probe can tell
    assert all(theirs[p] == "PermissionError" for p in paths), theirs
    assert theirs["7447"] != "connected" and stack.summary()["unanswered"]["fit"] == 0
