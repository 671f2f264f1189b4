"""The source service as a real process: frames, pacing, JPEG, end of stream, bad inputs."""

from __future__ import annotations

import subprocess
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from proto import EndOfStream, Frame
from services.bus.connection import BusOptions
from services.bus.images import image_of
from services.bus.options import options_argv
from services.bus.session import Service
from services.source.service import frame_problem


def source_argv(peer: Service, bus: BusOptions, *args: str) -> list[str]:
    return ["service", "source", *options_argv(bus), "--wait-for", "probe", "--wait-timeout", "60",
            *args]


def collect(peer: Service) -> tuple[list[Frame], list[EndOfStream]]:
    frames = peer.inbox("frame", capacity=512)
    eos = peer.inbox("eos", capacity=4)
    peer.ready()
    return frames, eos  # type: ignore[return-value]


def drain(inbox, first_within: float = 0.2) -> list:
    """What ``inbox`` holds, waiting up to ``first_within`` s for the first message."""
    out = []
    while (got := inbox.get(first_within if not out else 0.2)) is not None:
        out.append(got.message)
    return out


def received(frames, eos) -> tuple[list[Frame], list[EndOfStream]]:
    """The frames and ends of stream, once the end of stream arrived: it went out last, on
    the same link, so every frame before it is in by then, however slow the machine."""
    ends = drain(eos, first_within=60.0)
    return drain(frames), ends


def test_real_time_jpeg_frames_then_end_of_stream(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions], single_face: Path,
    run_cli: Callable[..., subprocess.CompletedProcess[str]],
) -> None:
    frames, eos = collect(peer)
    done = run_cli(*source_argv(peer, bus_pair[1], "--video", str(single_face),
                                "--max-frames", "30", "--jpeg", "85"))
    assert done.returncode == 0, done.stderr
    got, ends = received(frames, eos)
    assert [f.header.frame_index for f in got] == list(range(30))
    assert all(f.encoding == "jpeg" and image_of(f).shape == (360, 640, 3) for f in got)
    # Paced at the file's 30 frames/s: frame k never goes out before k / 30 s after frame 0
    # (a loaded machine may make it later; the schedule itself is test_pacing's, on a clock
    # the test moves).
    start = got[0].header.capture_time_ns
    early = [f.header.frame_index for f in got
             if f.header.capture_time_ns - start < f.header.frame_index * 1e9 / 30 - 2e6]
    assert not early, f"frames sent before their time: {early}"
    assert [f.header.media_time_ns for f in got] == [round(i * 1e9 / 30) for i in range(30)]
    assert len(ends) == 1 and ends[0].total_frames == 30 and ends[0].reason == "end_of_file"


def test_fast_pacing_goes_on_without_answers_after_the_timeout(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions], single_face: Path,
    run_cli: Callable[..., subprocess.CompletedProcess[str]],
) -> None:
    frames, eos = collect(peer)
    start = time.monotonic()
    done = run_cli(*source_argv(peer, bus_pair[1], "--video", str(single_face),
                                "--max-frames", "6", "--pace", "fast", "--window", "2",
                                "--answer-timeout", "0.2"))
    assert done.returncode == 0, done.stderr
    got, ends = received(frames, eos)
    assert [f.header.frame_index for f in got] == list(range(6))
    assert all(isinstance(f.image, np.ndarray) for f in got)  # raw by default
    # The file's clock, not the pace: frame i is at i / 30 s however fast it went out.
    assert [f.header.media_time_ns for f in got] == [round(i * 1e9 / 30) for i in range(6)]
    assert time.monotonic() - start >= 0.8  # frames 2..5 each waited for a lost answer
    assert ends[0].total_frames == 6


def test_a_url_that_does_not_answer_fails_with_end_of_stream_and_exit_1(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions],
    run_cli: Callable[..., subprocess.CompletedProcess[str]],
) -> None:
    from services.stack.launcher import free_port

    _, eos = collect(peer)
    done = run_cli(*source_argv(peer, bus_pair[1], "--url",
                                f"rtsp://127.0.0.1:{free_port()}/nothing"), timeout=60)
    assert done.returncode == 1
    assert "OpenCV cannot open it" in done.stderr
    ends = drain(eos, first_within=60.0)
    assert len(ends) == 1 and ends[0].total_frames == 0 and ends[0].reason.startswith("error:")


def test_frames_of_another_size_or_type_are_refused() -> None:
    ok = np.zeros((360, 640, 3), np.uint8)
    assert frame_problem(ok, (640, 360)) == ""
    assert "on a stream of 640 x 360" in frame_problem(ok[:100], (640, 360))
    assert "not (H, W, 3) uint8" in frame_problem(ok.astype(np.float32), (640, 360))
    assert "not (H, W, 3) uint8" in frame_problem(ok[:, :, 0], (640, 360))
