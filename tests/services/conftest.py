"""Fixtures of the service tests: real videos, a small cached model, stacks on loopback."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from aamcore.config import REPO_ROOT
from services.bus.connection import BusOptions
from services.bus.session import Service
from services.stack.launcher import free_port
from services.stack.options import StackOptions, parse_run_args


def run_argv(video: Path, **kw: object) -> list[str]:
    """``aamtrack run`` arguments of ``video`` and options given by field name."""
    argv = ["--video", str(video)]
    for name, value in kw.items():
        flag = "--" + name.replace("_", "-")
        if name == "extra":
            argv += [f"--set={service}:{arg}" for service, args in value.items()  # type: ignore
                     for arg in args]
        elif value is True:
            argv.append(flag)
        elif value is False:
            argv.append("--no-" + flag[2:])
        elif value is not None:
            argv += [flag, str(value)]
    return argv


def _run_cli(*args: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    env = os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO_ROOT)}
    return subprocess.run([sys.executable, "-m", "services", *args], capture_output=True,
                          text=True, timeout=timeout, env=env, cwd=REPO_ROOT)


@pytest.fixture(scope="session")
def stack_options(model_path: Path, classifier_path: Path) -> Callable[..., StackOptions]:
    """``stack_options(video, **options)``: a stack on ``video``, fast pacing, the small model
    and its classifier, the default endpoint (the stream's Unix socket, or one of the run's
    own while another stack holds it); options by field name, as ``aamtrack run`` takes
    them."""

    def make(video: Path, **kw: object) -> StackOptions:
        kw.setdefault("pace", "fast")
        kw.setdefault("drain_max", 10.0)
        kw.setdefault("model", str(model_path))
        kw.setdefault("classifier", str(classifier_path))
        return parse_run_args(run_argv(video, **kw))

    return make


@pytest.fixture(scope="session")
def run_cli() -> Callable[..., subprocess.CompletedProcess[str]]:
    """``run_cli(*args, timeout=120)``: ``python -m services ARGS`` in a subprocess, output
    captured, one compute thread."""
    return _run_cli


@pytest.fixture
def bus_pair() -> Iterator[tuple[BusOptions, BusOptions]]:
    """Bus options of two peers on a fresh loopback port: a listener and a connector."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    stream = f"t{os.getpid()}"
    yield (BusOptions(stream, listen=(endpoint,)),
           BusOptions(stream, listen=("tcp/127.0.0.1:0",), connect=(endpoint,)))


@pytest.fixture
def peer(bus_pair: tuple[BusOptions, BusOptions]) -> Iterator[Service]:
    """An open service session listening on the pair's endpoint (name ``probe``)."""
    with Service("probe", bus_pair[0], status_period=0.2, handle_signals=False) as svc:
        yield svc


@pytest.fixture(scope="session")
def two_faces(single_face: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A lossless 20-frame video of two real faces side by side (frames k and k + 36 of the
    face video)."""
    import cv2
    import numpy as np

    from aamcore.io.video import video_frames

    frames = video_frames(single_face)
    path = tmp_path_factory.mktemp("two_faces") / "two.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"FFV1"), 30, (1280, 360))
    for k in range(20):
        writer.write(np.hstack([frames[k], frames[k + 36]]))
    writer.release()
    return path
