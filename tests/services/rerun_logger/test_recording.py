"""Recordings go to a complete .rrd file and/or a gRPC server bound to loopback only."""

from __future__ import annotations

import socket
import time
from pathlib import Path

import pytest
import rerun as rr
from rerun.chunk import RrdReader

from services.rerun_logger.recording import open_recording


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def listening_addresses(port: int) -> set[str]:
    """Local IPv4 addresses (hex, as in /proc/net/tcp) listening on ``port``."""
    found = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in Path(table).read_text().splitlines()[1:]:
            local, state = line.split()[1], line.split()[3]
            address, port_hex = local.rsplit(":", 1)
            if state == "0A" and int(port_hex, 16) == port:
                found.add(address)
    return found


@pytest.mark.parametrize(
    ("kwargs", "problem"),
    [
        ({}, "give an .rrd path"),
        ({"rrd_path": "/nonexistent-folder/x.rrd"}, "does not exist"),
        ({"serve_port": 0}, "port 0"),
        ({"serve_port": 70000}, "port 70000"),
    ],
)
def test_open_recording_rejects_bad_outputs(kwargs, problem):
    with pytest.raises(ValueError, match=problem):
        open_recording(**kwargs)


def test_closed_file_is_complete(tmp_path, rrd_tools):
    read, verify = rrd_tools
    rec = open_recording(tmp_path / "a.rrd", recording_id="rec-1")
    for i in range(50):
        rec.stream.set_time("frame", sequence=i)
        rec.stream.log("x", rr.Scalars(float(i)))
    rec.close()
    verify(rec.rrd_path)
    reader = RrdReader(rec.rrd_path)
    assert [s.recording_id for s in reader.recordings()] == ["rec-1"]
    # A lazy store needs the footer that only closing writes.
    assert "/x" in reader.store().summary()
    assert read(rec.rrd_path).mono("/x", "Scalars:scalars") == [float(i) for i in range(50)]


@pytest.mark.skipif(not Path("/proc/net/tcp").is_file(), reason="needs Linux /proc/net/tcp")
def test_server_listens_on_loopback_only(tmp_path):
    port = free_port()
    rec = open_recording(tmp_path / "b.rrd", serve_port=port)
    try:
        assert rec.serve_uri is not None and f"127.0.0.1:{port}" in rec.serve_uri
        deadline = time.monotonic() + 5
        while not listening_addresses(port) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert listening_addresses(port) == {"0100007F"}  # 127.0.0.1, nothing else
        with socket.create_connection(("127.0.0.1", port), timeout=2):
            pass
    finally:
        rec.close()
    deadline = time.monotonic() + 5
    while listening_addresses(port) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not listening_addresses(port)
