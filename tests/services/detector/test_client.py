"""services.detector.client: boxes from the detector service, and a local fall-back that
searches as that service does."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np

from aamcore.config import REPO_ROOT
from aamcore.detection.haar import HaarFaceDetector
from proto import FaceBoxes, decode
from proto.keys import detect_key
from services.bus.connection import BusOptions
from services.bus.options import options_argv
from services.bus.session import Service
from services.detector.client import ServiceDetector
from tests.services.fitter.test_service import frames

OPTIONS = ["--scale-factor", "1.2", "--min-neighbors", "7", "--min-size", "60",
           "--max-side", "320"]
SETTINGS = {"scale_factor": 1.2, "min_neighbors": 7, "min_size": [60, 60], "max_side": 320,
            "equalize": False}


def test_the_local_fall_back_searches_with_the_detector_services_settings(
    bus_pair: tuple[BusOptions, BusOptions], single_face: Path
) -> None:
    image = frames(single_face, (0,))[0]
    env = os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO_ROOT)}
    with Service("fitter", bus_pair[0], handle_signals=False) as svc:
        proc = subprocess.Popen([sys.executable, "-m", "services", "service", "detector",
                                 *options_argv(bus_pair[1]), *OPTIONS], env=env, cwd=REPO_ROOT)
        try:
            assert svc.wait_for_alive(["detector"], 30) == [], "the detector did not start"
            client = ServiceDetector(svc, timeout=10.0, local_for=60.0)
            assert client.local_settings != SETTINGS  # the library's defaults before a reply
            asked = client.detect(image)
        finally:
            proc.send_signal(signal.SIGTERM)
            proc.wait(15)
        client.timeout = 0.3
        local = client.detect(image)
    assert client.queries == 2 and client.local_detections == 1
    assert client.local_settings == SETTINGS
    assert len(asked) >= 1 and np.array_equal(asked, local)
    assert np.array_equal(local, HaarFaceDetector.from_settings(SETTINGS).detect(image))


def test_a_reply_with_bad_settings_keeps_its_boxes_and_the_settings_had(
    bus_pair: tuple[BusOptions, BusOptions], single_face: Path
) -> None:
    image = frames(single_face, (0,))[0]
    attachments = [json.dumps(SETTINGS).encode(), b"{not json", json.dumps(
        SETTINGS | {"scale_factor": float("nan")}).encode(), b"[" * 5000,
        json.dumps(SETTINGS | {"extra": 1}).encode()]

    def answer(query: Any) -> None:
        frame = decode(query.payload.to_bytes(), "frame")
        boxes = FaceBoxes(fake.header_for(frame), frame.width, frame.height,
                          np.array([[1, 2, 30, 40]], np.float32), np.ones(1, np.float32))
        query.reply(query.key_expr, fake.encode(boxes), attachment=attachments.pop(0))

    with Service("detector", bus_pair[1], handle_signals=False) as fake, \
            Service("fitter", bus_pair[0], handle_signals=False) as svc:
        fake.queryable(detect_key(fake.stream), answer)
        fake.ready()
        assert svc.wait_for_alive(["detector"], 30) == []
        client = ServiceDetector(svc, timeout=5.0, local_for=60.0)
        got = [client.detect(image) for _ in range(5)]
        rejected = svc.stats.rejected
    assert all(np.array_equal(b, [[1, 2, 30, 40]]) for b in got)
    assert client.local_settings == SETTINGS
    # the unreadable, the non-finite and the extra setting are refused and counted; the
    # over-long one is not read at all
    assert rejected == 3
