"""services.cli.run_cmd: ``aamtrack run`` option errors at start, ``aamtrack service``."""

from __future__ import annotations

import json
import socket
import subprocess
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

from services.stack.recorder import read_recording
from tests.videos import decoded_frames, faststart


def test_service_command_runs_one_service(
    run_cli: Callable[..., subprocess.CompletedProcess[str]],
) -> None:
    done = run_cli("service", "pose", "--help", timeout=60)
    assert done.returncode == 0 and "--fov" in done.stdout and "--connect" in done.stdout
    assert "--estimator {contour,posit,contour+calib}" in done.stdout
    run = run_cli("run", "--help", timeout=60)
    assert run.returncode == 0 and "--estimator" in run.stdout


def _model_of_another_version(model_path: Path, out: Path) -> Path:
    with np.load(model_path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    header = json.loads(arrays["header"].tobytes())
    header["format_version"] = 1
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), np.uint8)
    np.savez(out, **arrays)
    return out


def _wide_video(path: Path) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 10, (4200, 16))
    for _ in range(3):
        writer.write(np.zeros((16, 4200, 3), np.uint8))
    writer.release()
    return path


def test_every_option_error_exits_2_at_start_with_one_line(
    run_cli: Callable[..., subprocess.CompletedProcess[str]], single_face: Path,
    model_path: Path, tmp_path: Path,
) -> None:
    text = tmp_path / "model.npz"
    text.write_text("not a model\n")
    cut = tmp_path / "cut.npz"
    cut.write_bytes(model_path.read_bytes()[:5000])
    old = _model_of_another_version(model_path, tmp_path / "old.npz")
    garbage = tmp_path / "cam.yaml"
    garbage.write_bytes(b"\x00\x01 not a calibration")
    nan = tmp_path / "nan.json"
    nan.write_text('{"camera_matrix": [[800, 0, 320], [0, 800, 240], [0, 0, 1]], '
                   '"image_width": NaN, "image_height": 480}')
    video = str(single_face)
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        busy_endpoint = f"tcp/127.0.0.1:{busy.getsockname()[1]}"
        cases = [
            (["--video", video, "--model", str(text)], "--model"),
            (["--video", video, "--model", str(cut)], "--model"),
            (["--video", video, "--model", str(old)], "model file format version 1"),
            (["--video", video, "--calibration", str(garbage)], "--calibration"),
            (["--video", video, "--calibration", str(nan)], "--calibration"),
            (["--video", video, "--fov", "0"], "--fov 0.0"),
            (["--video", video, "--jpeg", "500"], "--jpeg 500"),
            (["--video", video, "--loop", "-1"], "--loop -1"),
            (["--video", str(_wide_video(tmp_path / "wide.mp4"))], "exceed the frame limit"),
            (["--video", video, "--endpoint", busy_endpoint], "--endpoint"),
            (["--video", video, "--set", "fitter:--capacity=0"], "fitter: --capacity 0"),
            (["--video", video, "--host", "compute"], "--host goes with --stack"),
            (["--video", video, "--rrd", "/proc/x.rrd"], "--rrd /proc/x.rrd: cannot be written"),
            (["--video", video, "--rrd", str(tmp_path / "no" / "x.rrd")],
             "the folder " + str(tmp_path / "no") + " does not exist"),
            (["--video", video, "--rrd", str(tmp_path)], "is a folder"),
            (["--video", video, "--summary", str(tmp_path / "no" / "s.json")], "--summary"),
            (["--video", video, "--record", "/proc/x.rec"], "--record /proc/x.rec"),
            (["--camera", "7"], "--camera: camera 7"),
        ]
        for argv, expected in cases:
            done = run_cli("run", *argv, timeout=60)
            assert done.returncode == 2, (argv, done.stdout, done.stderr)
            lines = [line for line in done.stderr.splitlines() if line.strip()]
            assert len(lines) == 1 and expected in lines[0], (argv, done.stderr)
            assert "Traceback" not in done.stdout + done.stderr


def test_a_video_cut_short_fails_run_and_track_with_one_line_naming_its_last_frame(
    run_cli: Callable[..., subprocess.CompletedProcess[str]], single_face: Path,
    model_path: Path, classifier_path: Path, tmp_path: Path,
) -> None:
    whole = faststart(single_face.read_bytes())  # its index at the front: all 72 frames stated
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(whole[: len(whole) // 2])
    read = decoded_frames(cut)
    assert 10 < read < 72
    line = (f"{cut}: the video ended after frame {read - 1} ({read} of its 72 frames: cut "
            "short or damaged?)")
    models = ["--model", str(model_path), "--classifier", str(classifier_path)]
    summary = tmp_path / "summary.json"
    done = run_cli("run", "--video", str(cut), "--pace", "fast", "--no-ar", *models,
                   "--summary", str(summary), timeout=180)
    assert done.returncode == 1, done.stdout + done.stderr
    # The frames before the cut are processed and counted; one line says what happened.
    facts = json.loads(summary.read_text())
    assert facts["total_frames"] == read and facts["frames_with"]["fit"] <= read
    assert facts["unanswered"] == {"fit": 0, "pose": 0}
    problems = [x for x in done.stderr.splitlines()
                if any(w in x for w in ("error", "ERROR", "WARN", "Traceback"))]
    assert problems == [f"aamtrack run: error: {line}"], done.stderr
    out = tmp_path / "cut.csv"
    done = run_cli("track", str(cut), "--csv", str(out), *models)
    assert done.returncode == 1, done.stdout + done.stderr
    assert done.stderr.splitlines()[-1] == (f"aamtrack track: error: {line}; the rows of the "
                                            "frames before are written")
    assert len(out.read_text().splitlines()) == read + 1


def test_a_full_disk_ends_the_run_with_one_line_naming_the_file(
    run_cli: Callable[..., subprocess.CompletedProcess[str]], single_face: Path,
    model_path: Path, classifier_path: Path, tmp_path: Path,
) -> None:
    # A file name that is /dev/full takes the file and fails every write with "No space left
    # on device": a full disk for one file of the run, the others on a disk with room.
    full = tmp_path / "full.rec"
    full.symlink_to("/dev/full")
    models = ["--model", str(model_path), "--classifier", str(classifier_path), "--no-ar"]
    video = ["--video", str(single_face), "--pace", "fast", "--max-frames", "12"]
    done = run_cli("run", *video, *models, "--record", str(full), timeout=180)
    assert done.returncode == 2, done.stdout + done.stderr  # its first bytes fail: no start
    assert done.stderr.splitlines()[-1] == (
        f"aamtrack run: error: --record {full}: cannot be written (No space left on device)")
    full.unlink()
    full = tmp_path / "full.rrd"
    full.symlink_to("/dev/full")
    rec = tmp_path / "run.rec"
    done = run_cli("run", *video, *models, "--rrd", str(full), "--record", str(rec),
                   timeout=180)
    assert done.returncode == 1, done.stdout + done.stderr
    ours = [x for x in done.stderr.splitlines()  # all but the run's announcement (its key)
            if x.startswith("aamtrack run:") and not x.startswith("aamtrack run: run ")]
    assert len(ours) == 1 and ours[0].startswith(
        f"aamtrack run: error: --rrd {full}: cannot be written ("), ours
    assert "Traceback" not in done.stderr and "restarting rerun" not in done.stderr
    assert len(read_recording(rec).messages) > 12  # the other file is whole
