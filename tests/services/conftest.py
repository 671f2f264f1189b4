"""Fixtures of the service tests: real videos, a small cached model, stacks on loopback."""

# ruff: noqa: E402  (the repository root must be on sys.path before proto is imported)
from __future__ import annotations

import sys
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]
# Under pytest, tests/ is on sys.path and tests/proto (no __init__.py) would make
# ``proto`` a namespace package; spawned service processes inherit sys.path.
if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))

import os
import subprocess
from collections.abc import Callable, Iterator

import pytest

from services.bus.runtime import BusOptions, Service
from services.stack.launcher import StackOptions, free_port

MODEL_LIMIT = 120
"""Training images of the small test AAM (cached after the first run)."""
MODEL_IMAGES = 10


@pytest.fixture(scope="session")
def videos(data_dir: Path) -> Path:
    return data_dir / "videos"


@pytest.fixture(scope="session")
def single_face(videos: Path) -> Path:
    return videos / "single_face.mp4"


@pytest.fixture(scope="session")
def no_face(videos: Path) -> Path:
    return videos / "no_face.mp4"


@pytest.fixture(scope="session")
def model_path() -> Path:
    """A small LFPW AAM ready for fitting, from the user cache (trained on first use)."""
    from aamcore.fitting.training.prepare import default_model_path

    return default_model_path(max_images=MODEL_IMAGES, limit=MODEL_LIMIT)


@pytest.fixture(scope="session")
def classifier_path(model_path: Path) -> Path:
    """The expression classifier for :func:`model_path` (trained on JAFFE on first use)."""
    from aamcore.expression.training import classifier_path as cached

    return cached(model_path)


@pytest.fixture(scope="session")
def models(model_path: Path, classifier_path: Path) -> dict[str, list[str]]:
    """Model arguments per service, as :func:`services.stack.launcher.prepare_models` gives them."""
    return {"fitter": ["--model", str(model_path)],
            "expression": ["--model", str(model_path), "--classifier", str(classifier_path)]}


def _stack_options(video: Path, **kw: object) -> StackOptions:
    kw.setdefault("pace", "fast")
    kw.setdefault("drain_max", 10.0)
    kw.setdefault("endpoint", f"tcp/127.0.0.1:{free_port()}")
    return StackOptions(video=str(video), model_limit=MODEL_LIMIT, model_images=MODEL_IMAGES,
                        **kw)  # type: ignore[arg-type]


def _run_cli(*args: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    env = os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO_ROOT)}
    return subprocess.run([sys.executable, "-m", "services", *args], capture_output=True,
                          text=True, timeout=timeout, env=env, cwd=REPO_ROOT)


@pytest.fixture(scope="session")
def stack_options() -> Callable[..., StackOptions]:
    """``stack_options(video, **options)``: a stack on ``video``, fast pacing, the small model."""
    return _stack_options


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
