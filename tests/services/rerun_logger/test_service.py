"""The service, run as its own process on a real Zenoh bus, records a stream to a valid .rrd,
streams it to a real running Rerun viewer, or serves it until stopped."""

from __future__ import annotations

import multiprocessing
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
import zenoh

from aamcore.config import REPO_ROOT
from proto.codec import decode, encode
from proto.golden import golden_messages
from proto.keys import status_key, topic_key
from proto.messages import EndOfStream, Message, Status
from proto.zenoh_config import zenoh_config
from services.rerun_logger import entities as ent
from services.rerun_logger.annotations import PARTS
from tests.services.rerun_logger.conftest import has_event, wait_until

STREAM = "cam0"
KINDS = ("frame", "boxes", "fit", "pose", "expression", "overlay", "eos")
FAKE_SERVICE = "fitter"



def _run_service(argv: list[str]) -> None:
    """Process target: the service's ``main`` (imported here, in the spawned process)."""
    from services.rerun_logger.service import main

    sys.exit(main(argv))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Bus:
    """The test's side of the bus: a listening session, publishers and a status recorder."""

    def __init__(self) -> None:
        self.endpoint = f"tcp/127.0.0.1:{_free_port()}"
        self.session = zenoh.open(zenoh_config("peer", listen=[self.endpoint]))
        keys = [topic_key(STREAM, k) for k in KINDS] + [status_key(STREAM, FAKE_SERVICE)]
        self.publishers = {
            key: self.session.declare_publisher(
                key, congestion_control=zenoh.CongestionControl.BLOCK
            )
            for key in keys
        }
        self.statuses: list[Status] = []
        self._lock = threading.Lock()
        self._subscriber = self.session.declare_subscriber(
            status_key(STREAM, "rerun"), self._on_status
        )

    def _on_status(self, sample: Any) -> None:
        msg = decode(sample.payload.to_bytes(), "status")
        with self._lock:
            self.statuses.append(msg)

    def last_status(self) -> Status | None:
        with self._lock:
            return self.statuses[-1] if self.statuses else None

    def final_status(self, timeout: float = 5.0) -> Status:
        """The service's last status, ``stopped`` or ``failed``, once it has arrived."""
        deadline = time.monotonic() + timeout
        while (s := self.last_status()) is None or s.state not in ("stopped", "failed"):
            assert time.monotonic() < deadline, f"no final status; last: {s}"
            time.sleep(0.02)
        return s

    def wait_for_subscribers(self, timeout: float = 30.0) -> None:
        """Wait until the service subscribes to every key the test publishes on."""
        deadline = time.monotonic() + timeout
        while not all(p.matching_status.matching for p in self.publishers.values()):
            assert time.monotonic() < deadline, "the service never subscribed"
            time.sleep(0.02)

    def publish(self, msg: Message) -> None:
        self.publishers[msg.key()].put(encode(msg))

    def put(self, kind: str, payload: bytes) -> None:
        self.publishers[topic_key(STREAM, kind)].put(payload)

    def close(self) -> None:
        self._subscriber.undeclare()
        for publisher in self.publishers.values():
            publisher.undeclare()
        self.session.close()


@pytest.fixture
def bus() -> Iterator[Bus]:
    b = Bus()
    try:
        yield b
    finally:
        b.close()


def _start(bus: Bus, *args: str) -> multiprocessing.Process:
    argv = ["--stream", STREAM, "--mode", "peer", "--connect", bus.endpoint, "--unverified",
            *args]  # the test publishes without keys
    process = multiprocessing.get_context("spawn").Process(target=_run_service, args=(argv,))
    process.start()
    return process


def _stop(process: multiprocessing.Process) -> None:
    if process.is_alive():
        process.kill()
        process.join(5)


def _fake_status(index: int) -> Status:
    golden = golden_messages()["status"]
    return Status(golden.header, **(golden.to_dict() | {"frames_in": 10 * index}))


def test_service_records_a_stream_until_end_of_stream(
    bus, tmp_path, rrd_tools, faces, messages_of
):
    read, verify = rrd_tools
    rrd = tmp_path / "stream.rrd"
    process = _start(bus, "--rrd", str(rrd), "--idle", "0.3")
    try:
        bus.wait_for_subscribers()
        for i, face in enumerate(faces):
            for msg in messages_of(face, i):
                bus.publish(msg)
            bus.publish(_fake_status(i))
        bus.put("fit", b"\x00 not msgpack")
        bus.put("fit", encode(golden_messages()["pose"]))  # a pose on the fit key
        bus.publish(EndOfStream(messages_of(faces[-1], 2)[0].header, total_frames=3,
                                reason="end_of_file"))
        process.join(30)
        assert process.exitcode == 0
    finally:
        _stop(process)
    verify(rrd)
    content = read(rrd)
    for entity, column in [
        (ent.LANDMARKS, "Points2D:positions"),
        (ent.BOXES, "Boxes2D:centers"),
        (ent.HEAD, "Transform3D:translation"),
        (ent.EXPRESSION_SERIES + "/happy", "Scalars:scalars"),
        (ent.LATENCY_SERIES + "/pose", "Scalars:scalars"),
    ]:
        assert content.frames("/" + entity, column) == [0, 1, 2], entity
    np.testing.assert_array_equal(
        content.values("/" + ent.LANDMARKS, "Points2D:positions")[1],
        faces[1].points.astype(np.float32),
    )
    assert content.mono(f"/{ent.STATUS_SERIES}/{FAKE_SERVICE}/frames_in", "Scalars:scalars") == [
        0.0, 10.0, 20.0
    ]
    assert any("end of stream" in t for t in content.mono("/" + ent.EVENTS, "TextLog:text"))
    # Frames and overlays keep only the latest: the last one is always logged,
    # and every one not logged was counted as dropped.
    video = content.frames("/" + ent.VIDEO, "EncodedImage:blob")
    overlay = content.frames("/" + ent.OVERLAY, "EncodedImage:blob")
    assert video[-1] == 2 and overlay[-1] == 2
    final = bus.final_status()
    assert final.state == "stopped"
    assert final.rejected == 2
    assert final.dropped == (3 - len(video)) + (3 - len(overlay))


def test_service_stops_cleanly_on_sigterm_while_serving(bus, tmp_path, rrd_tools, faces,
                                                         messages_of):
    read, verify = rrd_tools
    rrd = tmp_path / "stopped.rrd"
    port = _free_port()
    process = _start(bus, "--rrd", str(rrd), "--serve", str(port))
    try:
        bus.wait_for_subscribers()
        for msg in messages_of(faces[0], 0):
            bus.publish(msg)
        deadline = time.monotonic() + 20
        while (s := bus.last_status()) is None or s.frames_in < 6:
            assert time.monotonic() < deadline, f"the service did not take the messages: {s}"
            time.sleep(0.05)
        with socket.create_connection(("127.0.0.1", port), timeout=2):
            pass  # a viewer can connect on loopback
        os.kill(process.pid, signal.SIGTERM)
        process.join(20)
        assert process.exitcode == 0
    finally:
        _stop(process)
    verify(rrd)
    content = read(rrd)
    assert content.frames("/" + ent.LANDMARKS, "Points2D:positions") == [0]
    assert content.frames("/" + ent.VIDEO, "EncodedImage:blob") == [0]
    assert bus.final_status().state == "stopped"


def _service_command(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "services.rerun_logger.service", *args],
        cwd=REPO_ROOT, capture_output=True, text=True, timeout=60,
    )


def test_service_refuses_to_run_without_an_output():
    done = _service_command("--stream", STREAM)
    assert done.returncode == 2
    assert "give --rrd PATH, --serve PORT and/or --viewer [URL]" in done.stderr


def _publish_stream(bus: Bus, faces: list, messages_of: Any) -> None:
    for i, face in enumerate(faces):
        for msg in messages_of(face, i):
            bus.publish(msg)
    bus.publish(EndOfStream(messages_of(faces[-1], len(faces) - 1)[0].header,
                            total_frames=len(faces), reason="end_of_file"))


def test_service_streams_to_a_running_viewer_and_saves_with_the_save_alias(
    bus, tmp_path, rrd_tools, faces, messages_of, rerun_server
):
    read, verify = rrd_tools
    viewer = rerun_server()
    rrd = tmp_path / "saved.rrd"
    process = _start(bus, "--viewer", viewer.url, "--save", str(rrd), "--idle", "0.3")
    try:
        bus.wait_for_subscribers()
        _publish_stream(bus, faces, messages_of)
        process.join(30)
        assert process.exitcode == 0
    finally:
        _stop(process)
    got = viewer.wait_for(has_event("end of stream"), "the end of stream in the viewer")
    verify(rrd)
    for content in (got, read(rrd)):
        assert content.frames("/" + ent.LANDMARKS, "Points2D:positions") == [0, 1, 2]
        assert content.frames("/" + ent.HEAD, "Transform3D:translation") == [0, 1, 2]
        class_ids = content.values("/" + ent.LANDMARKS, "Points2D:class_ids")[0]
        assert set(class_ids) == set(range(len(PARTS)))  # coloured by facial part
        assert len(content.static("/" + ent.GLASSES_FRAME, "Mesh3D:vertex_positions")) > 100
    assert bus.final_status().state == "stopped"


def test_service_with_a_viewer_that_is_not_running_exits_2_with_one_line(tmp_path):
    from tests.services.rerun_logger.conftest import free_port

    port = free_port()
    done = _service_command("--stream", STREAM, "--viewer", str(port),
                            "--rrd", str(tmp_path / "never.rrd"))
    assert done.returncode == 2
    assert "Traceback" not in done.stderr
    (line,) = [x for x in done.stderr.splitlines() if "ERROR" in x or "error" in x]
    assert f"no Rerun viewer at rerun+http://127.0.0.1:{port}/proxy" in line
    assert "connection refused" in line
    assert not (tmp_path / "never.rrd").exists()


def test_service_rejects_a_malformed_viewer_url():
    done = _service_command("--stream", STREAM, "--viewer", "http://127.0.0.1:9876/")
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert "--viewer 'http://127.0.0.1:9876/': expected rerun+http://HOST:PORT/proxy" in (
        done.stderr)


def test_service_keeps_serving_after_the_end_of_stream_until_stopped(
    bus, tmp_path, rrd_tools, faces, messages_of, rerun_server
):
    read, verify = rrd_tools
    rrd = tmp_path / "served.rrd"
    port = _free_port()
    process = _start(bus, "--rrd", str(rrd), "--serve", str(port), "--idle", "0.2")
    try:
        bus.wait_for_subscribers()
        _publish_stream(bus, faces[:2], messages_of)
        status = wait_until(lambda: (s := bus.last_status()) is not None
                            and s.state == "waiting" and s, "the service to serve on", 30)
        assert f"serving rerun+http://127.0.0.1:{port}/proxy until stopped" in status.message
        # A viewer connecting after the end of stream gets the whole recording.
        late = rerun_server("late", source=f"rerun+http://127.0.0.1:{port}/proxy")
        got = late.wait_for(has_event("end of stream"), "the recording in the late viewer")
        assert got.frames("/" + ent.LANDMARKS, "Points2D:positions") == [0, 1]
        assert process.is_alive() and process.exitcode is None
        os.kill(process.pid, signal.SIGTERM)
        process.join(20)
        assert process.exitcode == 0
    finally:
        _stop(process)
    verify(rrd)
    assert read(rrd).frames("/" + ent.LANDMARKS, "Points2D:positions") == [0, 1]
    assert bus.final_status().state == "stopped"


def test_service_on_its_own_refuses_a_stream_whose_run_s_keys_it_cannot_have(bus, tmp_path):
    """Started beside a bus with no launcher to vouch for the run's keys, and without
    --unverified: it logs nothing and says why (exit 2)."""
    done = _service_command("--stream", STREAM, "--connect", bus.endpoint, "--rrd",
                            str(tmp_path / "x.rrd"))
    assert done.returncode == 2, done.stderr
    assert "no run's keys on stream" in done.stderr and "Traceback" not in done.stderr


def test_service_reports_an_unwritable_rrd_path(tmp_path):
    done = _service_command("--stream", STREAM, "--rrd", str(tmp_path / "missing" / "x.rrd"))
    assert done.returncode == 2
    assert "cannot open the recording" in done.stderr and "does not exist" in done.stderr


def test_a_restarted_service_writes_a_new_part_and_keeps_the_first(
    bus, tmp_path, rrd_tools, faces, messages_of, monkeypatch
):
    read, verify = rrd_tools
    rrd = tmp_path / "run.rrd"
    rrd.write_bytes(b"what the first run wrote")
    monkeypatch.setenv("AAMTRACK_RESTARTS", "1")  # as the supervisor sets it on a restart
    process = _start(bus, "--rrd", str(rrd), "--idle", "0.3")
    try:
        bus.wait_for_subscribers()
        for msg in messages_of(faces[0], 0):
            bus.publish(msg)
        bus.publish(EndOfStream(messages_of(faces[0], 0)[0].header, total_frames=1,
                                reason="end_of_file"))
        process.join(30)
        assert process.exitcode == 0
    finally:
        _stop(process)
    assert rrd.read_bytes() == b"what the first run wrote"
    part = tmp_path / "run.part1.rrd"
    verify(part)
    assert read(part).frames("/" + ent.LANDMARKS, "Points2D:positions") == [0]
