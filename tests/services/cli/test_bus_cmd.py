"""services.cli.bus_cmd: one-line message descriptions, ``echo`` and ``record`` beside a stack."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from aamcore.config import REPO_ROOT
from proto import EndOfStream, Frame
from proto.golden import golden_messages
from services.bus.connection import BusOptions
from services.bus.options import options_argv
from services.bus.session import Service
from services.cli.bus_cmd import describe, record_keys
from services.stack.recorder import load_messages


def test_every_kind_is_described_on_one_line() -> None:
    lines = {kind: describe(msg) for kind, msg in golden_messages().items()}
    assert set(lines) == {"frame", "boxes", "fit", "pose", "expression", "overlay", "status",
                          "eos"}
    for kind, line in lines.items():
        assert "\n" not in line and line.startswith(kind) and " #" in line, line
    assert "roll" in lines["pose"] and "yaw" in lines["pose"]
    assert "frames" in lines["eos"] and "dropped" in lines["status"]


def test_record_keys_leave_images_out_unless_asked() -> None:
    keys = record_keys("cam0", frames=False, overlays=False)
    assert "aamtrack/cam0/fit" in keys and "aamtrack/cam0/status/*" in keys
    assert not any(k.endswith(("/frame", "/overlay")) for k in keys)
    assert "aamtrack/cam0/frame" in record_keys("cam0", frames=True, overlays=False)


def start(*args: str) -> subprocess.Popen[str]:
    env = os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO_ROOT)}
    return subprocess.Popen([sys.executable, "-m", "services", *args], env=env, cwd=REPO_ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def publish_until_done(peer: Service, proc: subprocess.Popen[str], waiting_for: str) -> None:
    """Publish a frame, a fit-less end of stream and garbage until ``proc`` exits."""
    assert peer.wait_for_alive([waiting_for], 30) == []
    deadline = time.monotonic() + 30
    i = 0
    while proc.poll() is None and time.monotonic() < deadline:
        peer.publish(Frame.from_array(peer.header(i), np.zeros((8, 8, 3), np.uint8)))
        peer.publish(EndOfStream(peer.header(i), total_frames=i + 1, reason="end_of_file"))
        peer.put(peer.key("eos"), b"\xc1garbage")
        i += 1
        time.sleep(0.1)


def test_echo_prints_one_line_per_message(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions]
) -> None:
    proc = start("echo", f"aamtrack/{peer.stream}/**", *options_argv(bus_pair[1]), "--count", "4",
                 "--timeout", "30", "--unverified")  # the peer has no keys
    peer.ready()
    publish_until_done(peer, proc, "echo")
    out, err = proc.communicate(timeout=10)
    assert proc.returncode == 0, err
    lines = out.splitlines()
    assert len(lines) == 4
    assert {line.split()[0] for line in lines} <= {"frame", "eos", "rejected", "status"}
    assert any(line.startswith("frame") and "8x8 raw" in line for line in lines), (lines, err)
    assert "UNVERIFIED" in err and "malformed" in err  # said, and the garbage counted


def test_record_writes_results_but_not_frames(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions], tmp_path: Path
) -> None:
    out = tmp_path / "run.rec"
    # No fit ever comes for the end of stream's last frame: the recording ends after
    # --drain-max seconds.
    proc = start("record", "--out", str(out), *options_argv(bus_pair[1]), "--until-eos",
                 "--drain-max", "1", "--timeout", "30", "--unverified")
    peer.ready()
    publish_until_done(peer, proc, "record")
    _, err = proc.communicate(timeout=10)
    assert proc.returncode == 0, err
    kinds = [m.KIND for m in load_messages(out)]
    assert "eos" in kinds and "frame" not in kinds
    assert "recorded" in err and "UNVERIFIED" in err


def test_echo_and_record_give_up_without_a_stack(tmp_path: Path) -> None:
    from services.stack.launcher import free_port

    nowhere = f"tcp/127.0.0.1:{free_port()}"
    for args in (["echo", "aamtrack/**"], ["record", "--out", str(tmp_path / "r.rec")]):
        started = time.monotonic()
        proc = start(*args, "--connect", nowhere, "--timeout", "1")
        _, err = proc.communicate(timeout=60)
        assert proc.returncode == 1, err
        assert f"no aamtrack stack answered at {nowhere} within 1 s" in err
        assert "Traceback" not in err
        assert time.monotonic() - started < 30


def test_echo_and_record_refuse_a_stack_whose_run_s_keys_they_cannot_have(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions], tmp_path: Path
) -> None:
    """A stack without a launcher (the peer has no keys): without --unverified, nothing is
    printed or recorded, and the command says why."""
    for args in (["echo", f"aamtrack/{peer.stream}/**"],
                 ["record", "--out", str(tmp_path / "r.rec")]):
        proc = start(*args, *options_argv(bus_pair[1]), "--timeout", "2")
        out, err = proc.communicate(timeout=60)
        assert proc.returncode == 1 and out == "", err
        assert "no run's keys on stream" in err and "Traceback" not in err
