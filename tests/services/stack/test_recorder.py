"""services.stack.recorder: recordings written, flushed, read back, and damaged files read up
to the damage."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from aamcore.config import REPO_ROOT
from proto import EndOfStream, Fit, FitAppearance, Header, encode
from services.stack.recorder import (
    MAGIC,
    RecordingError,
    RecordWriter,
    load_messages,
    read_recording,
)


def messages() -> list:
    h = Header.now("cam0", 1, "fitter")
    fit = Fit(h, "ibug68", np.ones((68, 2), np.float32), np.array([1.0, 0.0, 0.0, 0.0], np.float32),
              640, 480, False, "", 0.9, "gpu",
              FitAppearance(np.zeros(3, np.float32), np.zeros((3, 4), np.float32), 0.5, 4, True,
                            np.zeros(68, np.uint8)))
    return [fit, EndOfStream(Header.now("cam0", 1, "source"), total_frames=2, reason="end")]


def write(path: Path) -> bytes:
    with RecordWriter(path) as writer:
        for m in messages():
            writer.write(encode(m))
    return path.read_bytes()


def test_messages_come_back_in_order(tmp_path: Path) -> None:
    path = tmp_path / "sub" / "run.rec"
    data = write(path)
    assert data.startswith(MAGIC)
    loaded = load_messages(path)
    assert [m.KIND for m in loaded] == ["fit", "eos"]
    assert np.array_equal(loaded[0].landmarks, np.ones((68, 2))) and loaded[1].total_frames == 2
    assert [m.KIND for m in load_messages(path, ["eos"])] == ["eos"]


def test_not_a_recording_is_refused(tmp_path: Path) -> None:
    bad = tmp_path / "bad.rec"
    bad.write_bytes(b"NOT-A-RECORDING\n" + write(tmp_path / "run.rec")[len(MAGIC):])
    with pytest.raises(RecordingError, match="bad magic"):
        read_recording(bad)


@pytest.mark.parametrize(("damage", "kept", "where"), [
    (lambda d: d[:-5], 1, "record 1 at byte .*: truncated"),
    (lambda d: d + (2**31).to_bytes(4, "little"), 2, "record 2 at byte .*: claims 2147483648"),
    (lambda d: d + (3).to_bytes(4, "little") + b"\x93ab", 2, "record 2 at byte .* does not decode"),
    (lambda d: d + b"\x01\x00", 2, "record 2 at byte .*: truncated in its length"),
])
def test_a_damaged_recording_gives_every_record_before_the_damage(
    tmp_path: Path, damage, kept: int, where: str
) -> None:
    bad = tmp_path / "bad.rec"
    bad.write_bytes(damage(write(tmp_path / "run.rec")))
    recording = read_recording(bad)
    assert len(recording.messages) == kept
    assert re.search(where, recording.stopped), recording.stopped
    assert len(load_messages(bad)) == kept


def test_a_writer_killed_mid_run_leaves_a_readable_recording(tmp_path: Path) -> None:
    """The writer flushes once a second of its clock has passed since its last flush:
    SIGKILL loses at most the last second. Its clock moves 0.3 s a record here."""
    path = tmp_path / "killed.rec"
    payload = encode(messages()[1]).hex()
    assert len(payload) // 2 * 11 < 4096  # less than the file's buffer: only flushes write
    script = (
        "import sys\n"
        "from services.stack.recorder import RecordWriter\n"
        "now = [0.0]\n"
        f"w = RecordWriter({str(path)!r}, clock=lambda: now[0])\n"
        f"p = bytes.fromhex({payload!r})\n"
        "for i in range(11):\n"
        "    now[0] = 0.3 * i\n"
        "    w.write(p)\n"
        "print('written', flush=True)\n"
        "sys.stdin.read()\n"  # until killed
    )
    env = os.environ | {"PYTHONPATH": str(REPO_ROOT)}
    proc = subprocess.Popen([sys.executable, "-c", script], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True, env=env)
    assert proc.stdout is not None and proc.stdout.readline().strip() == "written"
    proc.send_signal(signal.SIGKILL)
    proc.wait(60)
    # Flushed at records 4 (1.2 s) and 8 (2.4 s): 0-8 are in the file; 9 and 10 (0.6 s) may
    # not be.
    recording = read_recording(path)
    assert 9 <= len(recording.messages) <= 11


def test_messages_after_close_are_left_out_and_counted(tmp_path: Path) -> None:
    # The monitor's subscriber thread may still deliver while the run stops.
    path = tmp_path / "run.rec"
    writer = RecordWriter(path)
    writer.write(encode(messages()[0]))
    writer.close()
    writer.write(encode(messages()[1]))
    assert writer.late == 1
    assert [type(m).__name__ for m in load_messages(path)] == ["Fit"]


def test_a_recording_keeps_only_what_its_run_s_services_signed(tmp_path: Path) -> None:
    """Read with the run's public keys it holds: a forged, an unsigned, another key's and a
    replayed message are left out and counted; a recording of another launcher is refused
    under --trust."""
    from proto.auth import Keyring, keys_document

    ring = Keyring.generate(["fitter", "source", "launcher"])
    fit, eos = messages()
    fitter, source = ring.for_service("fitter"), ring.for_service("source")
    forger = Keyring.generate(["fitter"]).for_service("fitter")
    path = tmp_path / "run.rec"
    with RecordWriter(path, keys_document(ring, "cam0", "")) as writer:
        for payload in (fitter.encode(fit), encode(fit), forger.encode(fit),
                        fitter.encode(fit), source.encode(eos)):
            writer.write(payload)
    recording = read_recording(path)
    assert [m.KIND for m in recording.messages] == ["fit", "eos"]
    assert recording.ignored == {"unsigned": 1, "bad signature": 1, "replayed": 1}
    assert recording.verified.endswith(ring.fingerprint)
    assert read_recording(path, trust=ring.fingerprint).messages == recording.messages
    with pytest.raises(RecordingError, match="is not the trusted"):
        read_recording(path, trust=Keyring.generate(["launcher"]).fingerprint)
    write(tmp_path / "plain.rec")  # a run without keys
    unverified = read_recording(tmp_path / "plain.rec")
    assert len(unverified.messages) == 2 and unverified.run_keys is None
    assert unverified.verified.startswith("unverified")
