"""Fixtures shared by the detection and initialisation tests: IMM data and its detections."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aamcore.detection.haar import HaarFaceDetector
from aamcore.io import AnnotatedSet, load_annotated_folder


@pytest.fixture(scope="session")
def imm_set(imm_dir: Path) -> AnnotatedSet:
    return load_annotated_folder(imm_dir)


@pytest.fixture(scope="session")
def detector() -> HaarFaceDetector:
    return HaarFaceDetector()


@pytest.fixture(scope="session")
def imm_detections(imm_set: AnnotatedSet, detector: HaarFaceDetector) -> list[np.ndarray]:
    """Haar boxes of every IMM image, computed once (about 3 s)."""
    return [detector.detect(s.load_image()) for s in imm_set.samples]
