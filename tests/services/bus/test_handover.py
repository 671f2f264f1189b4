"""services.bus.handover: keys go only to the process that asked, once it says it is
non-dumpable and untraced, over the fresh channel it made; anything else is refused."""

from __future__ import annotations

import array
import json
import os
import socket
import threading

import pytest

from proto.auth import Keyring
from services.bus.handover import (
    REFUSED,
    HandoverError,
    ProcessGone,
    give_keys,
    receive_keys,
    spawn_channel,
)

RING = Keyring.generate(["fitter", "source"]).for_service("fitter")


def _ask(service_end: socket.socket, report: dict) -> socket.socket:
    """Send a key request with a fresh channel made by this process; its other end."""
    mine, theirs = socket.socketpair()
    fds = array.array("i", [theirs.fileno()])
    service_end.sendmsg([json.dumps(report).encode()],
                        [(socket.SOL_SOCKET, socket.SCM_RIGHTS, fds)])
    theirs.close()
    return mine


def _answer(sock: socket.socket) -> bytes:
    sock.shutdown(socket.SHUT_WR)
    return b"".join(iter(lambda: sock.recv(65536), b""))


def test_a_channel_made_by_another_process_is_refused() -> None:
    launcher_end, service_end = spawn_channel()
    mine = _ask(service_end, {"dumpable": False, "tracer": 0})
    with pytest.raises(HandoverError, match=f"made by pid {os.getpid()}"):
        give_keys(launcher_end, os.getpid() + 1, "fitter", RING, timeout=5)
    assert _answer(mine) == REFUSED


def test_a_dumpable_or_traced_process_gets_no_key_unless_insecure() -> None:
    for report, why in (({"dumpable": True, "tracer": 0}, "non-dumpable"),
                        ({"dumpable": False, "tracer": 4242}, "traced")):
        launcher_end, service_end = spawn_channel()
        mine = _ask(service_end, report)
        with pytest.raises(HandoverError, match=why):
            give_keys(launcher_end, os.getpid(), "fitter", RING, timeout=5)
        assert _answer(mine) == REFUSED
    launcher_end, service_end = spawn_channel()
    mine = _ask(service_end, {"dumpable": True, "tracer": 0})
    handed = give_keys(launcher_end, os.getpid(), "fitter", RING, insecure=True, timeout=5)
    assert "non-dumpable" in handed.problem
    assert json.loads(_answer(mine))["keyring"] == RING.to_bytes().decode()


def test_no_request_in_time_and_a_request_without_a_channel_are_refused() -> None:
    launcher_end, service_end = spawn_channel()
    with pytest.raises(HandoverError, match="never asked for its keys"):
        give_keys(launcher_end, os.getpid(), "fitter", RING, timeout=0.2)
    # Another process holds the channel open after the service died: a death, restarted.
    with pytest.raises(ProcessGone, match="ended before it asked"):
        give_keys(launcher_end, os.getpid(), "fitter", RING, timeout=30, alive=lambda: False)
    service_end.sendall(b'{"dumpable": false, "tracer": 0}')  # no fresh socket with it
    with pytest.raises(HandoverError, match="carried no fresh socket"):
        give_keys(launcher_end, os.getpid(), "fitter", RING, timeout=5)


def test_a_service_gets_its_keyring_and_its_floors() -> None:
    launcher_end, service_end = spawn_channel()
    floors = {("source", "frame"): 41}
    got: list = []
    service = threading.Thread(target=lambda: got.append(receive_keys(service_end.detach())))
    service.start()
    give_keys(launcher_end, os.getpid(), "fitter", RING, floors, insecure=True, timeout=30)
    service.join(30)
    assert got == [(RING, floors)]
