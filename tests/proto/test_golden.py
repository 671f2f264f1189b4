"""The committed golden payloads: byte-exact encodings and their decoded values."""

from __future__ import annotations

import re
from pathlib import Path

import cv2
import numpy as np
import pytest

from aamcore.config import REPO_ROOT
from proto.codec import decode, encode
from proto.golden import CAPTURE_NS, golden_messages, main
from proto.header import SCHEMA_VERSION
from proto.messages import MESSAGE_TYPES, Message

README = REPO_ROOT / "proto" / "README.md"


def test_there_is_one_golden_file_and_message_per_kind(
    golden: dict[str, Message], golden_files: dict[str, bytes]
) -> None:
    assert list(golden) == list(MESSAGE_TYPES)
    assert set(golden_files) == set(MESSAGE_TYPES)


@pytest.mark.parametrize("kind", list(MESSAGE_TYPES))
def test_encoding_reproduces_the_golden_file_byte_for_byte(
    kind: str, golden: dict[str, Message], golden_files: dict[str, bytes]
) -> None:
    assert encode(golden[kind]) == golden_files[kind]
    assert decode(golden_files[kind], kind) == golden[kind]


def test_golden_files_decode_to_the_expected_values(golden_files: dict[str, bytes]) -> None:
    msgs = {kind: decode(payload, kind) for kind, payload in golden_files.items()}
    for msg in msgs.values():
        assert msg.header.stream_id == "cam0" and msg.header.capture_time_ns == CAPTURE_NS
        assert msg.header.publish_time_ns - msg.header.capture_time_ns == 5_000_000
    frame, boxes, fit, pose = msgs["frame"], msgs["boxes"], msgs["fit"], msgs["pose"]
    assert (frame.width, frame.height, frame.image.shape) == (6, 4, (4, 6, 3))
    assert frame.image[1, 2].tolist() == [24, 25, 26]
    assert boxes.boxes.tolist() == [[200.5, 120.25, 180.0, 180.0], [10.0, 20.0, 30.0, 40.0]]
    assert boxes.scores.tolist() == [0.875, 0.25]
    assert fit.header.frame_index == 42 and fit.header.producer == "fitter"
    assert fit.landmarks.shape == (68, 2) and fit.landmarks[18].tolist() == [108.5, 162.25]
    assert fit.appearance.c.tolist() == [0.5, -1.25, 0.125, 2.0, -0.0625]
    found = fit.appearance
    assert (found.iterations, found.converged, fit.failed, fit.warp_path) == (0, True, False, "gpu")
    assert found.texture_residual.shape == (4, 5) and found.occluded[48:60].tolist() == [1] * 12
    assert pose.rotation[2].tolist() == [-0.6, 0.0, 0.8]
    assert pose.translation_mm.tolist() == [12.5, -30.0, 650.0] and pose.yaw_deg == 36.87
    assert pose.intrinsics[0].tolist() == [800.0, 0.0, 320.0]
    expression = msgs["expression"]
    assert expression.label == "happy" and expression.class_names[3] == "surprise"
    assert expression.scores[1] == 45 / 64
    status = msgs["status"]
    assert (status.service, status.state, status.frames_in, status.dropped) == (
        "fitter",
        "running",
        1000,
        8,
    )
    assert status.header.frame_index == 999 and status.latency_p99_ms == 11.25
    assert (msgs["eos"].total_frames, msgs["eos"].reason) == (43, "end_of_file")


def test_overlay_holds_a_real_jpeg(golden_files: dict[str, bytes]) -> None:
    overlay = decode(golden_files["overlay"], "overlay")
    image = cv2.imdecode(np.frombuffer(overlay.image, np.uint8), cv2.IMREAD_UNCHANGED)
    assert image.shape == (overlay.height, overlay.width) == (8, 8)
    assert abs(int(image.mean()) - 128) <= 1


def test_the_regeneration_script_writes_the_committed_files(
    tmp_path: Path, golden_files: dict[str, bytes], capsys: pytest.CaptureFixture[str]
) -> None:
    assert main([str(tmp_path / "golden")]) == 0
    written = {p.stem: p.read_bytes() for p in (tmp_path / "golden").glob("*.msgpack")}
    assert written == golden_files
    assert len(capsys.readouterr().out.splitlines()) == len(golden_messages())


def test_readme_worked_example_is_the_golden_eos_payload(golden_files: dict[str, bytes]) -> None:
    text = README.read_text()
    block = re.search(r"```hex\n(.*?)```", text, re.DOTALL)
    assert block is not None, "proto/README.md lost its ```hex block"
    hex_digits = re.sub(r"[^0-9a-f]", "", re.sub(r"#.*", "", block.group(1)))
    assert bytes.fromhex(hex_digits) == golden_files["eos"]
    assert f"SCHEMA_VERSION = {SCHEMA_VERSION}" in text or f"version {SCHEMA_VERSION}" in text
