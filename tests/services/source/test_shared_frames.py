"""Frames written once into shared memory by the source process, and what happens where
shared memory is full (a reader holds every buffer) or missing: the run goes on over the
network, every frame arrives, one warning, the fall-back counted (a pool too small for an
image: ``tests/services/bus/test_shm.py``)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import pytest

from aamcore.config import REPO_ROOT
from proto import Frame, Status
from proto.keys import status_key
from services.bus.connection import BusOptions
from services.bus.options import options_argv
from services.bus.session import Service

FRAMES = 20


class Watcher:
    """The frames the probe receives (holding each payload when asked: a reader that holds
    every shared-memory buffer it is given) and the source's last status."""

    def __init__(self, peer: Service, hold: bool = False) -> None:
        self.frames: list[Frame] = []
        self.held: list[Any] = []
        self.hold = hold
        self._lock = threading.Lock()
        peer.subscribe(peer.key("frame"), self.on_frame)
        self.status = peer.inbox(status_key(peer.stream, "source"), 64, kind="status")
        self.peer = peer
        peer.ready()

    def on_frame(self, sample: Any) -> None:
        frame = self.peer.screen.check(sample.payload.to_bytes(), str(sample.key_expr), "frame")
        with self._lock:
            if frame is not None:
                self.frames.append(frame)
            if self.hold:
                self.held.append(sample.payload)

    def last_status(self) -> Status:
        last = None
        while (got := self.status.get(timeout=5)) is not None:
            last = got.message
            if last.state in ("stopped", "failed"):
                return last
        raise AssertionError(f"no final status of the source (last: {last})")


def run_source(peer: Service, bus: BusOptions, video: Path, *args: str,
               prefix: tuple[str, ...] = ()) -> subprocess.CompletedProcess[str]:
    argv = [*prefix, sys.executable, "-m", "services", "service", "source", *options_argv(bus),
            "--wait-for", "probe", "--wait-timeout", "20", "--video", str(video),
            "--max-frames", str(FRAMES), *args]
    env = os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO_ROOT)}
    return subprocess.run(argv, capture_output=True, text=True, timeout=120, env=env,
                          cwd=REPO_ROOT)


def warnings(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines()
            if "WARNING" in line and "images go over the network" in line]


def test_frames_go_through_shared_memory_once_written(
        peer: Service, bus_pair: tuple[BusOptions, BusOptions], single_face: Path) -> None:
    watch = Watcher(peer)
    done = run_source(peer, bus_pair[1], single_face)
    assert done.returncode == 0, done.stderr
    status = watch.last_status()
    assert f"images in shared memory {FRAMES}, over the network 0" in status.message
    assert [f.header.frame_index for f in watch.frames] == list(range(FRAMES))
    assert not warnings(done.stderr)


def test_without_a_pool_every_frame_goes_over_the_network_unwarned(
        peer: Service, bus_pair: tuple[BusOptions, BusOptions], single_face: Path) -> None:
    watch = Watcher(peer)
    done = run_source(peer, bus_pair[1], single_face, "--shm-frames", "0")
    assert done.returncode == 0, done.stderr
    assert not warnings(done.stderr)  # asked for: not a fall-back
    status = watch.last_status()
    assert (f"images in shared memory 0, over the network {FRAMES} (off {FRAMES})"
            in status.message)
    assert [f.header.frame_index for f in watch.frames] == list(range(FRAMES))


def test_a_reader_holding_every_buffer_costs_the_source_shared_memory_not_time(
        peer: Service, bus_pair: tuple[BusOptions, BusOptions], single_face: Path) -> None:
    """The probe keeps every payload it gets, so the pool (room for two frames) fills: the
    source goes on over the network, and every frame arrives."""
    watch = Watcher(peer, hold=True)
    done = run_source(peer, bus_pair[1], single_face, "--shm-frames", "2")
    assert done.returncode == 0, done.stderr
    status = watch.last_status()
    assert "images in shared memory 2, over the network" in status.message, status.message
    assert f"over the network {FRAMES - 2} (full {FRAMES - 2})" in status.message
    said = warnings(done.stderr)
    assert len(said) == 1 and "pool has been full for 6 images in a row" in said[0], said
    assert [f.header.frame_index for f in watch.frames] == list(range(FRAMES))


def _unshare_prefix() -> tuple[str, ...]:
    """A prefix that runs a command where /dev/shm is read-only (a mount namespace of its
    own), or () where this machine does not allow it."""
    unshare = shutil.which("unshare")
    if unshare is None:
        return ()
    prefix = (unshare, "-rm", "sh", "-c",
              'mount -t tmpfs -o ro tmpfs /dev/shm && exec "$@"', "sh")
    probe = subprocess.run([*prefix, "sh", "-c", "touch /dev/shm/x"], capture_output=True)
    return prefix if probe.returncode != 0 and b"Read-only" in probe.stderr else ()


def test_without_shared_memory_the_frames_go_over_the_network(
        peer: Service, bus_pair: tuple[BusOptions, BusOptions], single_face: Path) -> None:
    prefix = _unshare_prefix()
    if not prefix:
        pytest.skip("no user and mount namespaces here to take /dev/shm away")
    watch = Watcher(peer)
    done = run_source(peer, bus_pair[1], single_face, prefix=prefix)
    assert done.returncode == 0, done.stderr
    assert len(warnings(done.stderr)) == 1 and "no shared memory" in done.stderr
    status = watch.last_status()
    assert (f"images in shared memory 0, over the network {FRAMES} (unavailable {FRAMES})"
            in status.message)
    assert [f.header.frame_index for f in watch.frames] == list(range(FRAMES))
