"""End to end: the whole stack as real processes on a loopback Zenoh bus, on real videos.

Each test starts every service with the spawn method (detector, fitter, pose,
expression, optionally the glasses renderer and the Rerun logger, then the
source), runs a video through, and checks what came out of the recording the
launcher keeps and the services' last statuses.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import msgpack
import numpy as np
import pytest

from proto import Fit, Frame, encode
from services.bus.runtime import BusOptions, Service
from services.stack.launcher import Stack, StackOptions, free_port, module_exists
from services.stack.recorder import load_messages

HAVE_RERUN = module_exists("services.rerun_logger.service")
RERUN_CLI = Path(sys.executable).with_name("rerun")


def run_stack(opts: StackOptions, models: dict[str, list[str]]) -> tuple[Stack, dict]:
    with Stack(opts, models) as stack:
        outcome = stack.wait()
    assert outcome == "done", stack.summary()
    return stack, stack.summary()


def decoded_frames(video: Path) -> int:
    """Frames OpenCV decodes from ``video`` (container counts can be off)."""
    cap = cv2.VideoCapture(str(video))
    n = 0
    while cap.read()[0]:
        n += 1
    cap.release()
    return n


def by_frame(messages: list, kind: str) -> dict[int, object]:
    return {m.header.frame_index: m for m in messages if kind == m.KIND}


def assert_accounted(summary: dict, service: str = "fitter") -> None:
    """Every frame published was answered by ``service`` or counted as dropped or rejected."""
    s = summary["services"][service]
    assert s["frames_in"] + s["dropped"] == summary["total_frames"], s
    assert s["frames_out"] == s["frames_in"] - s["rejected"] or s["rejected"] == 0


def rrd_entities(path: Path) -> set[str]:
    from rerun.chunk import RrdReader

    return {chunk.entity_path for chunk in RrdReader(path).stream()}


def test_single_face_gpu_warp_every_frame_gets_its_results(
    single_face: Path, models: dict[str, list[str]], tmp_path: Path,
    stack_options: Callable[..., StackOptions],
) -> None:
    rrd, rec = tmp_path / "run.rrd", tmp_path / "run.rec"
    opts = stack_options(single_face, warp="gpu", record=str(rec),
                         rrd=str(rrd) if HAVE_RERUN else None)
    stack, summary = run_stack(opts, models)
    assert summary["total_frames"] == 72 and summary["eos_reason"] == "end_of_file"
    messages = load_messages(rec)
    fits = by_frame(messages, "fit")
    assert sorted(fits) == list(range(72))
    assert {f.warp_path for f in fits.values()} == {"gpu"}
    reasons = sorted({f.failure_reason for f in fits.values() if f.failed})
    assert all(not f.failed for f in fits.values()), f"failed fits: {reasons}"
    assert sorted(by_frame(messages, "pose")) == list(range(72))
    assert sorted(by_frame(messages, "expression")) == list(range(72))
    assert all(p.reliable for p in by_frame(messages, "pose").values())
    assert summary["messages"]["overlay"] > 0
    assert summary["services"]["ar"]["frames_out"] == summary["messages"]["overlay"]
    assert all(code == 0 for code in stack.exit_codes.values()), stack.exit_codes
    for name, s in summary["services"].items():
        assert s["state"] == "stopped" and s["rejected"] == 0, (name, s)
    assert summary["services"]["fitter"]["dropped"] == 0  # fast pacing waits for each fit
    if HAVE_RERUN:
        done = subprocess.run([str(RERUN_CLI), "rrd", "verify", str(rrd)], capture_output=True,
                              text=True, timeout=60)
        assert done.returncode == 0, done.stdout + done.stderr
        entities = rrd_entities(rrd)
        for entity in ("/world/camera/video", "/world/camera/landmarks", "/world/head",
                       "/overlay"):
            assert entity in entities, sorted(entities)


def test_single_face_cpu_warp_with_jpeg_frames(
    single_face: Path, models: dict[str, list[str]], tmp_path: Path,
    stack_options: Callable[..., StackOptions],
) -> None:
    rec = tmp_path / "run.rec"
    opts = stack_options(single_face, warp="cpu", jpeg=90, ar=False, record=str(rec))
    _, summary = run_stack(opts, models)
    fits = by_frame(load_messages(rec, ["fit"]), "fit")
    assert sorted(fits) == list(range(72))
    assert {f.warp_path for f in fits.values()} == {"cpu"}
    assert summary["frames_with"]["pose"] == summary["frames_with"]["expression"] == 72
    assert_accounted(summary)


def test_no_face_video_every_frame_is_answered_as_no_face(
    no_face: Path, models: dict[str, list[str]], tmp_path: Path,
    stack_options: Callable[..., StackOptions],
) -> None:
    rec = tmp_path / "run.rec"
    stack, summary = run_stack(stack_options(no_face, ar=False, record=str(rec)), models)
    total = decoded_frames(no_face)
    assert summary["total_frames"] == total > 90
    fits = by_frame(load_messages(rec, ["fit"]), "fit")
    assert sorted(fits) == list(range(total))
    assert all(f.failed and f.failure_reason == "no face" and len(f.landmarks) == 0
               for f in fits.values())
    assert summary["frames_with"]["pose"] == 0 and summary["frames_with"]["expression"] == 0
    assert summary["services"]["detector"]["frames_out"] >= total  # a query per frame at least
    assert all(code == 0 for code in stack.exit_codes.values()), stack.exit_codes


@pytest.mark.parametrize("kind", ["missing", "corrupt"])
def test_bad_video_file_exits_non_zero_with_a_message(
    kind: str, tmp_path: Path, run_cli: Callable[..., subprocess.CompletedProcess[str]]
) -> None:
    video = tmp_path / "clip.mp4"
    if kind == "corrupt":
        video.write_bytes(b"this is not a video\n" * 100)
    done = run_cli("run", "--video", str(video), timeout=60)
    assert done.returncode == 2
    expected = "no such file" if kind == "missing" else "OpenCV cannot open it"
    assert expected in done.stdout, done.stdout + done.stderr


def test_a_stream_url_that_does_not_answer_stops_the_run_with_exit_1(
    run_cli: Callable[..., subprocess.CompletedProcess[str]],
) -> None:
    url = f"rtsp://127.0.0.1:{free_port()}/nothing"
    done = run_cli("run", "--url", url, "--no-ar", "--model-limit", "120", "--model-images",
                   "10", "--endpoint", f"tcp/127.0.0.1:{free_port()}", timeout=120)
    assert done.returncode == 1
    assert f"aamtrack run: error: stream {url}: OpenCV cannot open it" in done.stdout


def _old_version(payload: bytes) -> bytes:
    obj = msgpack.unpackb(payload, raw=False)
    obj["header"]["schema_version"] = 0
    return msgpack.packb(obj, use_bin_type=True)


def inject_bad_messages(intruder: Service) -> None:
    """Publish malformed, oversized, old-schema and wrongly sized messages on the stack's keys."""
    frame = Frame.from_array(intruder.header(3), np.zeros((24, 32, 3), np.uint8))
    fit = Fit(intruder.header(3), "ibug68", np.zeros((68, 2), np.float32) + 100,
              np.zeros(5, np.float32), np.zeros(4, np.float32), 0.0, 1, True, False, "", "cpu")
    for _ in range(20):  # a flood: each reason must still be logged once
        intruder.put(intruder.key("frame"), b"\x93not a message")
        intruder.put(intruder.key("fit"), b"\xc1" * (2 << 20))  # over the 1 MiB limit
    intruder.put(intruder.key("fit"), _old_version(encode(fit)))
    intruder.put(intruder.key("frame"), encode(frame))  # a frame of another size


def test_malformed_and_oversized_messages_are_rejected_and_counted(
    single_face: Path, models: dict[str, list[str]], stack_options: Callable[..., StackOptions]
) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    opts = stack_options(single_face, ar=False, loop=2, endpoint=endpoint)
    with Stack(opts, models) as stack:
        bus = BusOptions(opts.stream, listen=("tcp/127.0.0.1:0",), connect=(endpoint,))
        with Service("intruder", bus, handle_signals=False) as intruder:
            deadline = time.monotonic() + 60
            while stack.monitor.counts["fit"] < 10:
                assert time.monotonic() < deadline, "the stack produced no fits"
                time.sleep(0.05)
            inject_bad_messages(intruder)
            assert stack.wait() == "done"
    summary = stack.summary()
    total, fits = summary["total_frames"], summary["frames_with"]["fit"]
    fitter, pose = summary["services"]["fitter"], summary["services"]["pose"]
    assert total == 144
    # The burst of garbage can push real frames out of the fitter's latest-4 inbox:
    # those are counted as dropped, every other real frame is answered.
    assert fits + fitter["dropped"] >= total and fits >= total - 4, fitter
    assert fitter["rejected"] + fitter["dropped"] >= 21, fitter  # 20 garbage, 1 wrong size
    assert fitter["rejected"] >= 1
    for s in (pose, summary["services"]["expression"]):
        # 20 oversized fits and one of schema version 0: taken and rejected, or pushed
        # out of the latest-8 inbox by the burst and counted as dropped.
        assert s["rejected"] >= 1 and s["rejected"] + s["dropped"] >= 21, s
    assert all(code == 0 for code in stack.exit_codes.values()), stack.exit_codes


def test_killing_a_service_leaves_the_others_running_and_it_comes_back(
    single_face: Path, models: dict[str, list[str]], stack_options: Callable[..., StackOptions]
) -> None:
    opts = stack_options(single_face, ar=False, pace="realtime", loop=3)
    with Stack(opts, models) as stack:
        deadline = time.monotonic() + 60
        while stack.monitor.counts["pose"] < 5:
            assert time.monotonic() < deadline, "the stack produced no poses"
            time.sleep(0.05)
        pid = stack.supervisor.pid("pose")
        assert pid is not None
        os.kill(pid, signal.SIGKILL)
        killed_at = len(stack.monitor.indices["fit"])
        assert stack.wait() == "done"
    summary = stack.summary()
    assert any("pose died" in e for e in summary["events"]), summary["events"]
    assert summary["services"]["pose"]["restarts"] == 1
    poses = stack.monitor.indices["pose"]
    assert max(poses) > killed_at + 30, "no poses after the restart"
    assert_accounted(summary)
    for name in ("detector", "fitter", "expression", "source"):
        assert summary["services"][name]["restarts"] == 0
