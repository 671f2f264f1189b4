"""Fixtures of the library tests: a real EGL context, IMM detections, a small fitting model."""

from __future__ import annotations

from collections.abc import Iterator

import moderngl
import numpy as np
import pytest

from aamcore.detection.haar import HaarFaceDetector
from aamcore.io import AnnotatedSet
from aamcore.synth.motion import Sequence
from tests.aamcore.truth import clip


@pytest.fixture(scope="module")
def gl_ctx() -> Iterator[moderngl.Context]:
    """A standalone EGL context, current in the main thread where the tests run.

    Module-scoped so that no context outlives the GL tests: a process holding
    one must not fork (see STACK_NOTES), and other tests may start processes.
    """
    ctx = moderngl.create_standalone_context(backend="egl")
    yield ctx
    ctx.release()


@pytest.fixture(scope="session")
def detector() -> HaarFaceDetector:
    return HaarFaceDetector()


@pytest.fixture(scope="session")
def imm_detections(imm_set: AnnotatedSet, detector: HaarFaceDetector) -> list[np.ndarray]:
    """Haar boxes of every IMM image, computed once (about 3 s)."""
    return [detector.detect(s.load_image()) for s in imm_set.samples]


@pytest.fixture(scope="session")
def moving_face(lfpw_dir) -> Sequence:
    """A held-out LFPW face moving slowly over 40 frames, with its exact landmarks
    (:mod:`tests.aamcore.truth`)."""
    return clip(lfpw_dir)
