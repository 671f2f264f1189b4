"""services.cli.export_cmd: a recording's rows as CSV / JSON Lines / .rrd, and ``track``."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest

from aamcore.results import EXPRESSION_REASONS, REASONS, explained
from proto import Fit
from services.stack.launcher import Stack
from services.stack.options import StackOptions
from services.stack.recorder import load_messages
from tests.expectations import FRAMES, GOOD_SHARE

RERUN = Path(sys.executable).with_name("rerun")


@pytest.fixture(scope="module")
def recording(single_face: Path, stack_options: Callable[..., StackOptions],
              tmp_path_factory: pytest.TempPathFactory) -> Path:
    rec = tmp_path_factory.mktemp("export") / "run.rec"
    with Stack(stack_options(single_face, ar=False, record=str(rec))) as stack:
        assert stack.wait() == "done"
    return rec


def _frames_read(video: Path) -> int:
    capture, read = cv2.VideoCapture(str(video)), 0
    while capture.read()[0]:
        read += 1
    return read


def test_a_recording_exports_one_row_per_frame_matching_its_messages(
    recording: Path, single_face: Path, tmp_path: Path,
    run_cli: Callable[..., subprocess.CompletedProcess[str]],
) -> None:
    out_csv, out_jsonl, out_rrd = tmp_path / "run.csv", tmp_path / "run.jsonl", tmp_path / "r.rrd"
    drawn = tmp_path / "run.mp4"
    done = run_cli("export", str(recording), "--csv", str(out_csv), "--jsonl", str(out_jsonl),
                   "--rrd", str(out_rrd), "--annotate", str(drawn), "--video", str(single_face))
    assert done.returncode == 0, done.stderr
    assert f"exported 72 rows (72 frames) of {recording}" in done.stderr
    assert _frames_read(drawn) == 72
    messages = load_messages(recording)
    fits = {m.header.frame_index: m for m in messages if isinstance(m, Fit)}
    poses = {m.header.frame_index: m for m in messages if m.KIND == "pose"}
    labels = {m.header.frame_index: m.label for m in messages if m.KIND == "expression"}
    rows = list(csv.DictReader(out_csv.open()))
    assert [int(r["frame"]) for r in rows] == sorted(fits) == list(range(72))
    for r in rows:
        k = int(r["frame"])
        fit = fits[k]
        assert r["success"] == str(int(not fit.failed))
        assert float(r["confidence"]) == pytest.approx(float(fit.confidence), abs=1e-4)
        np.testing.assert_allclose([float(r[f"x_{i}"]) for i in range(68)],
                                   fit.landmarks[:, 0], atol=1e-3)
        np.testing.assert_allclose([float(r[f"y_{i}"]) for i in range(68)],
                                   fit.landmarks[:, 1], atol=1e-3)
        pose = poses[k]
        np.testing.assert_allclose([float(r[c]) for c in ("pose_Tx", "pose_Ty", "pose_Tz")],
                                   pose.translation_mm, rtol=1e-5, atol=1e-3)
        assert float(r["pose_yaw"]) == pytest.approx(pose.yaw_deg, abs=1e-4)
        assert r["pose_reliable"] == str(int(pose.reliable))
        assert r["expression"] == labels.get(k, "")  # none while the reference is learned
    lines = [json.loads(line) for line in out_jsonl.read_text().splitlines()]
    assert len(lines) == 72 and [r["expression"] for r in lines] == [labels.get(k) for k in
                                                                     range(72)]
    assert labels and lines[71]["expression"] == labels[71]
    verified = subprocess.run([str(RERUN), "rrd", "verify", str(out_rrd)], capture_output=True)
    assert verified.returncode == 0


def test_a_damaged_recording_keeps_what_came_before_and_exits_1(
    recording: Path, tmp_path: Path, run_cli: Callable[..., subprocess.CompletedProcess[str]],
) -> None:
    cut = tmp_path / "cut.rec"
    data = recording.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    out = tmp_path / "cut.csv"
    done = run_cli("export", str(cut), "--csv", str(out))
    assert done.returncode == 1 and "damaged" in done.stderr and "Traceback" not in done.stderr
    rows = list(csv.DictReader(out.open()))
    assert 10 < len(rows) < 72
    foreign = tmp_path / "foreign.rec"
    foreign.write_bytes(b"PK\x03\x04 not a recording")
    done = run_cli("export", str(foreign), "--csv", str(tmp_path / "f.csv"))
    assert done.returncode == 2 and "not an aamtrack recording" in done.stderr
    assert "Traceback" not in done.stderr


def test_track_writes_the_rows_of_a_video_and_says_when_it_is_cut_short(
    single_face: Path, model_path: Path, classifier_path: Path, tmp_path: Path,
    run_cli: Callable[..., subprocess.CompletedProcess[str]],
) -> None:
    out, drawn = tmp_path / "track.csv", tmp_path / "track.mp4"
    done = run_cli("track", str(single_face), "--csv", str(out), "--model", str(model_path),
                   "--classifier", str(classifier_path), "--annotate", str(drawn))
    assert done.returncode == 0, done.stderr
    assert _frames_read(drawn) == FRAMES
    lines = done.stderr.splitlines()  # not a terminal: lines, no bar
    assert "aamtrack: tracking single_face.mp4: started (72 frames)" in lines
    assert lines[-1].startswith(f"tracked 72 frames of {single_face} in ")
    assert "\r" not in done.stderr
    rows = list(csv.DictReader(out.open()))
    assert len(rows) == FRAMES and sum(r["success"] == "1" for r in rows) >= GOOD_SHARE * FRAMES
    assert all(r["pose_Tz"] for r in rows if r["success"] == "1")
    # expressions: a label or the reason there is none on every row
    assert all(bool(r["expression"]) != bool(r["expression_reason"]) for r in rows)
    assert sum(bool(r["expression"]) for r in rows) >= GOOD_SHARE * FRAMES
    # every reason given is one the README and the help explain
    assert all(explained(r["expression_reason"], EXPRESSION_REASONS)
               for r in rows if r["expression_reason"])
    assert all(explained(r["reason"], REASONS) for r in rows if r["reason"])
    avi = tmp_path / "clip.avi"
    capture = cv2.VideoCapture(str(single_face))
    writer = cv2.VideoWriter(str(avi), cv2.VideoWriter_fourcc(*"MJPG"), 30, (640, 360))
    while (frame := capture.read())[0]:
        writer.write(frame[1])
    writer.release()
    cut = tmp_path / "cut.avi"
    cut.write_bytes(avi.read_bytes()[: avi.stat().st_size // 2])
    out = tmp_path / "cut.csv"
    done = run_cli("track", str(cut), "--csv", str(out), "--model", str(model_path),
                   "--classifier", str(classifier_path))
    assert done.returncode == 1 and "ended after" in done.stderr
    assert "Traceback" not in done.stderr
    assert 10 < len(list(csv.DictReader(out.open()))) < 72
    done = run_cli("track", str(tmp_path / "missing.mp4"), "--csv", str(out))
    assert done.returncode == 2 and "no such file" in done.stderr


def test_track_writes_a_row_per_face_with_its_id(
    two_faces: Path, model_path: Path, tmp_path: Path,
    run_cli: Callable[..., subprocess.CompletedProcess[str]],
) -> None:
    two = two_faces
    out = tmp_path / "two.csv"
    done = run_cli("track", str(two), "--csv", str(out), "--model", str(model_path),
                   "--max-faces", "2", "--no-expression")
    assert done.returncode == 0, done.stderr
    rows = list(csv.DictReader(out.open()))
    assert not any(r["expression"] or r["expression_reason"] for r in rows)
    by_frame: dict[str, list[dict[str, str]]] = {}
    for r in rows:
        by_frame.setdefault(r["frame"], []).append(r)
    assert sorted(map(int, by_frame)) == list(range(20))
    pairs = [fs for fs in by_frame.values() if len(fs) == 2 and all(r["face_id"] for r in fs)]
    assert len(pairs) >= GOOD_SHARE * 20
    assert len({tuple(r["face_id"] for r in fs) for fs in pairs}) == 1
    done = run_cli("track", str(two), "--csv", str(out), "--max-faces", "0", timeout=60)
    assert done.returncode == 2 and "--max-faces 0: must be a whole number from 1 to 64" in (
        done.stderr)


def test_outputs_and_numbers_are_checked_before_any_work(
    single_face: Path, model_path: Path, tmp_path: Path,
    run_cli: Callable[..., subprocess.CompletedProcess[str]],
) -> None:
    missing = tmp_path / "no" / "out.csv"
    text = tmp_path / "notes.mp4"
    text.write_text("not a video\n" * 40)  # FFmpeg's "moov atom not found" is not shown
    cases = [
        (("track", str(single_face), "--csv", str(missing), "--model", str(model_path)),
         f"--csv {missing}: the folder {missing.parent} does not exist"),
        (("track", str(single_face), "--jsonl", str(tmp_path), "--model", str(model_path)),
         "is a folder"),
        (("track", str(single_face), "--csv", str(tmp_path / "a.csv"), "--fov", "-5"),
         "--fov -5.0: must be a number from 1 to 179"),
        (("export", str(single_face), "--rrd", "/proc/x.rrd"), "--rrd /proc/x.rrd"),
        (("record", "--out", "/proc/x.rec"), "--out /proc/x.rec: cannot be written"),
        (("track", str(single_face), "--annotate", str(tmp_path / "no" / "a.mp4")),
         f"--annotate {tmp_path / 'no' / 'a.mp4'}: the folder {tmp_path / 'no'} does not exist"),
        (("track", str(single_face), "--annotate", "/proc/a.mp4"),
         "--annotate /proc/a.mp4: cannot be written"),
        (("track", str(single_face), "--annotate", str(tmp_path / "a.mkv")),
         "write a .mp4 or .avi file (not .mkv)"),
        (("export", str(single_face), "--annotate", str(tmp_path / "a.mp4")),
         "--annotate and --video go together"),
        (("track", str(tmp_path), "--csv", str(tmp_path / "a.csv")),
         f"{tmp_path}: is a folder, not a video file"),
        (("track", str(text), "--csv", str(tmp_path / "a.csv")),
         f"{text}: OpenCV cannot open it (not a video OpenCV can decode)"),
    ]
    for argv, expected in cases:
        done = run_cli(*argv, timeout=180)
        lines = [line for line in done.stderr.splitlines() if line.strip()]
        assert done.returncode == 2 and len(lines) == 1 and expected in lines[0], (argv, lines)
    assert not (tmp_path / "a.csv").exists()


def test_an_annotated_export_refuses_a_video_the_run_was_not_made_from(
    recording: Path, videos: Path, tmp_path: Path,
    run_cli: Callable[..., subprocess.CompletedProcess[str]],
) -> None:
    other = videos / "no_face.mp4"
    done = run_cli("export", str(recording), "--annotate", str(tmp_path / "a.mp4"),
                   "--video", str(other), timeout=60)
    assert done.returncode == 2 and done.stderr.splitlines() == [
        f"aamtrack export: error: {recording} is a run of 72 frames and {other} has 98: give "
        "--video the video the run was made from"]
    assert not (tmp_path / "a.mp4").exists()
