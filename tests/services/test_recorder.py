"""services.stack.recorder: recordings written, read back, and damaged files named."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from proto import EndOfStream, Fit, Header, encode
from services.stack.recorder import (
    MAGIC,
    RecordingError,
    RecordWriter,
    load_messages,
    read_payloads,
)


def messages() -> list:
    h = Header.now("cam0", 1, "fitter")
    fit = Fit(h, "ibug68", np.ones((68, 2), np.float32), np.zeros(3, np.float32),
              np.zeros(4, np.float32), 0.5, 4, True, False, "", "gpu")
    return [fit, EndOfStream(Header.now("cam0", 1, "source"), total_frames=2, reason="end")]


def test_messages_come_back_in_order(tmp_path: Path) -> None:
    path = tmp_path / "sub" / "run.rec"
    with RecordWriter(path) as writer:
        for m in messages():
            writer.write(encode(m))
    assert writer.count == 2 and path.read_bytes().startswith(MAGIC)
    loaded = load_messages(path)
    assert [m.KIND for m in loaded] == ["fit", "eos"]
    assert np.array_equal(loaded[0].landmarks, np.ones((68, 2))) and loaded[1].total_frames == 2
    assert [m.KIND for m in load_messages(path, ["eos"])] == ["eos"]
    with pytest.raises(ValueError, match="closed"):
        writer.write(b"x")


def test_damaged_recordings_are_named(tmp_path: Path) -> None:
    path = tmp_path / "run.rec"
    with RecordWriter(path) as writer:
        for m in messages():
            writer.write(encode(m))
    data = path.read_bytes()
    bad = tmp_path / "bad.rec"
    bad.write_bytes(b"NOT-A-RECORDING\n" + data[len(MAGIC):])
    with pytest.raises(RecordingError, match="bad magic"):
        list(read_payloads(bad))
    bad.write_bytes(data[:-5])
    with pytest.raises(RecordingError, match="truncated inside record 1"):
        load_messages(bad)
    bad.write_bytes(MAGIC + (2**31).to_bytes(4, "little"))
    with pytest.raises(RecordingError, match="claims 2147483648 bytes"):
        list(read_payloads(bad))
    bad.write_bytes(MAGIC + (3).to_bytes(4, "little") + b"\x93ab")
    with pytest.raises(RecordingError, match="record 0 does not decode"):
        load_messages(bad)
