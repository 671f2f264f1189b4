"""The detector service as a real process: queries answered with boxes, bad queries refused."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest

from aamcore.config import REPO_ROOT
from proto import Frame, decode, encode
from proto.keys import detect_key
from services.bus.connection import BusOptions
from services.bus.options import options_argv
from services.bus.session import Service


def first_frame(video: Path) -> np.ndarray:
    cap = cv2.VideoCapture(str(video))
    ok, image = cap.read()
    cap.release()
    assert ok
    return image


@pytest.fixture
def detector(peer: Service, bus_pair: tuple[BusOptions, BusOptions]) -> Iterator[
        subprocess.Popen[str]]:
    env = os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO_ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "services", "service", "detector",
                             *options_argv(bus_pair[1])], env=env, cwd=REPO_ROOT,
                            stderr=subprocess.PIPE, text=True)
    try:
        assert peer.wait_for_alive(["detector"], 30) == [], "the detector did not start"
        yield proc
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(15)


def ask(peer: Service, payload: bytes) -> list:
    return list(peer.session.get(detect_key(peer.stream), payload=payload, timeout=10.0))


def test_queries_get_the_boxes_of_their_frame(
    peer: Service, detector: subprocess.Popen[str], single_face: Path, no_face: Path
) -> None:
    published = peer.inbox("boxes", capacity=8)
    face = Frame.from_array(peer.header(5), first_frame(single_face))
    replies = ask(peer, encode(face))
    assert len(replies) == 1 and replies[0].ok is not None
    boxes = decode(replies[0].ok.payload.to_bytes(), "boxes")
    assert boxes.header.frame_index == 5 and (boxes.image_width, boxes.image_height) == (640, 360)
    assert len(boxes.boxes) >= 1
    x, y, w, h = boxes.boxes[0]
    assert 80 <= w <= 360 and x >= 0 and x + w <= 640 and y + h <= 360
    nothing = Frame.from_array(peer.header(6), first_frame(no_face))
    empty = decode(ask(peer, encode(nothing))[0].ok.payload.to_bytes(), "boxes")
    assert len(empty.boxes) == 0 and empty.scores.shape == (0,)
    got = published.get(5.0)
    assert got is not None and got.message.header.frame_index == 5


def test_a_query_that_is_not_a_frame_gets_an_error_reply_and_the_service_goes_on(
    peer: Service, detector: subprocess.Popen[str], single_face: Path
) -> None:
    bad = ask(peer, b"\x92not a frame")
    assert len(bad) == 1 and bad[0].ok is None
    assert b"not a valid frame" in bad[0].err.payload.to_bytes()
    good = ask(peer, encode(Frame.from_array(peer.header(0), first_frame(single_face))))
    assert good[0].ok is not None
    assert detector.poll() is None


def test_the_detector_stops_cleanly_on_sigterm(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions], detector: subprocess.Popen[str]
) -> None:
    detector.send_signal(signal.SIGTERM)
    assert detector.wait(15) == 0
