"""services.expression.service: classifying fits, smoothing, and running without a classifier."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np

from aamcore.config import REPO_ROOT
from aamcore.detection.haar import HaarFaceDetector
from aamcore.expression.recogniser import ExpressionRecogniser
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.io.jaffe import load_jaffe
from proto import Fit, Header
from proto.keys import status_key
from services.bus.connection import BusOptions
from services.bus.options import options_argv
from services.bus.session import Service
from services.expression.service import expression_message, load_classifier


def happy_fit(model_path: Path, data_dir: Path, index: int) -> Fit:
    """A fit of the AAM to a happy JAFFE face, as the fitter would publish it."""
    sample = next(s for s in load_jaffe(data_dir / "jaffe").samples if s.label == "HA")
    image = sample.load_image()
    box = HaarFaceDetector().detect(image)[0]
    result = Fitter(FittingModel.load(model_path), appearance=True).fit_box(image, box)
    sim = result.similarity
    return Fit(Header.now("cam0", index, "fitter"), "ibug68", result.points.astype(np.float32),
               result.c.astype(np.float32), np.array([sim.a, sim.b, sim.tx, sim.ty], np.float32),
               image.shape[1], image.shape[0], result.error, 5, True, False, "", "cpu",
               result.confidence)


def test_load_classifier_says_why_there_is_none(
    model_path: Path, classifier_path: Path, tmp_path: Path
) -> None:
    assert load_classifier(None, None) == (None, "no expression classifier given (--classifier)")
    none, why = load_classifier(str(tmp_path / "gone.npz"), None)
    assert none is None and "not found" in why
    other = tmp_path / "other-model.npz"
    other.write_bytes(model_path.read_bytes() + b"\0")
    none, why = load_classifier(str(classifier_path), str(other))
    assert none is None and "retrain it for this AAM" in why
    classifier, why = load_classifier(str(classifier_path), str(model_path))
    assert classifier is not None and why == ""


def test_a_happy_face_is_classified(
    model_path: Path, classifier_path: Path, data_dir: Path
) -> None:
    classifier, _ = load_classifier(str(classifier_path), str(model_path))
    fit = happy_fit(model_path, data_dir, 4)
    with Service("expression", BusOptions("cam0"), handle_signals=False) as svc:
        message = expression_message(svc, fit, ExpressionRecogniser(classifier))
    assert message.header.frame_index == 4 and not message.smoothed
    assert message.class_names == classifier.class_names and len(message.scores) == 7
    assert message.label == "HA"  # a training face: the classifier has seen it


def test_without_a_classifier_the_service_runs_degraded_and_says_why(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions]
) -> None:
    statuses = peer.inbox(status_key(peer.stream, "expression"), capacity=16, kind="status")
    env = os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO_ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "services", "service", "expression",
                             *options_argv(bus_pair[1])], env=env, cwd=REPO_ROOT,
                            stderr=subprocess.PIPE, text=True)
    try:
        assert peer.wait_for_alive(["expression"], 30) == []
        got = statuses.get(10.0)
        assert got is not None
        assert got.message.state == "degraded"
        assert "no expression classifier given" in got.message.message
    finally:
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=15)
    assert proc.returncode == 0
    assert "no expression classifier given" in err
