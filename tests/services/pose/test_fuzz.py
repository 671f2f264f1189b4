"""The pose service as a real process survives well-formed but extreme fits: landmarks
spread over a pixel or two, tall and wide frames, points far outside the frame."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from aamcore.config import REPO_ROOT
from aamcore.pose.errors import IntrinsicsError, PoseError
from aamcore.pose.estimator import Cameras, HeadPoseEstimator
from proto import Fit, Header
from services.bus.connection import BusOptions
from services.bus.options import options_argv
from services.bus.session import Service
from tests.services.pose.test_service import marked_face


def extreme_fits(n: int, seed: int = 0) -> Iterator[tuple[np.ndarray, int, int]]:
    """``(landmarks (68, 2), width, height)``: tiny spreads on frames of any shape, and
    shapes far outside their frame."""
    rng = np.random.default_rng(seed)
    for k in range(n):
        width, height = (int(v) for v in rng.integers(16, 4096, size=2))
        centre = rng.uniform([0, 0], [width, height]) * (1 if k % 4 else 5)
        spread = 10 ** rng.uniform(-3, 1.5)
        yield centre + spread * rng.standard_normal((68, 2)), width, height


@pytest.mark.parametrize("method", ["contour", "posit", "contour+calib"])
def test_extreme_landmarks_give_a_pose_or_a_pose_error(method: str) -> None:
    estimator = HeadPoseEstimator(Cameras(60.0), method=method)
    for landmarks, width, height in extreme_fits(300):
        try:
            pose = estimator.estimate(landmarks, width, height)
        except (PoseError, IntrinsicsError) as exc:  # nothing else escapes
            assert str(exc)
            continue
        # points scattered at random are no face: a pose, if any, flagged with its reason
        assert not pose.estimate.reliable and pose.reason, (method, pose.reason)


def test_an_error_while_answering_is_counted_and_the_service_goes_on() -> None:
    with Service("probe", BusOptions("t"), handle_signals=False) as svc:
        for _ in range(3):
            with svc.answering("a message"):
                raise RuntimeError("something unforeseen")
        assert svc.stats.failed == 3 and svc.status().failed == 3


@pytest.fixture
def pose_service(peer: Service, bus_pair: tuple[BusOptions, BusOptions]
                 ) -> Iterator[subprocess.Popen[str]]:
    env = os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO_ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "services", "service", "pose",
                             *options_argv(bus_pair[1])], env=env, cwd=REPO_ROOT,
                            stderr=subprocess.PIPE, text=True)
    try:
        assert peer.wait_for_alive(["pose"], 30) == [], "the pose service did not start"
        yield proc
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(15)


def test_a_flood_of_extreme_fits_leaves_the_pose_service_answering(
    peer: Service, pose_service: subprocess.Popen[str], data_dir: Path
) -> None:
    poses = peer.inbox("pose", capacity=512)
    sent = 0
    for k, (landmarks, width, height) in enumerate(extreme_fits(150, seed=1)):
        peer.publish(Fit(Header.now(peer.stream, k, "fitter"), "ibug68",
                         landmarks.astype(np.float32), np.ones(4, np.float32), width, height,
                         False, "", 0.5, "none", None))
        sent += 1
        time.sleep(0.005)
    points, size = marked_face(data_dir, "einstein")
    deadline = time.monotonic() + 30
    last = None
    while last is None and time.monotonic() < deadline:  # a real face, until it is answered
        peer.publish(Fit(Header.now(peer.stream, sent, "fitter"), "ibug68",
                         points.astype(np.float32), np.ones(4, np.float32), size[0], size[1],
                         False, "", 0.9, "none", None))
        time.sleep(0.2)
        while (got := poses.get(timeout=0)) is not None:
            if got.message.header.frame_index == sent:
                last = got.message
    assert pose_service.poll() is None, pose_service.stderr.read() if pose_service.stderr else ""
    assert last is not None and last.reliable
