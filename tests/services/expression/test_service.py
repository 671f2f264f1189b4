"""services.expression.service: fits classified with their frames, as the library does; the
reasons counted; running without a classifier or with fits of another model."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from aamcore.config import REPO_ROOT
from aamcore.expression import ExpressionClassifier
from aamcore.expression.faces import stack_observations
from aamcore.expression.recogniser import STACK_HOLD
from aamcore.fitting.model import FittingModel
from aamcore.io.jaffe import load_jaffe
from aamcore.operators.expression import ExpressionOperator
from aamcore.operators.options import PIPELINE
from proto import Fit, FitAppearance, Frame, Header, decode, encode
from proto.keys import status_key, topic_key
from services.bus.connection import BusOptions
from services.bus.options import options_argv
from services.bus.qos import MUST_ARRIVE
from services.bus.session import Service
from services.expression.service import Unclassified, load_classifier
from services.messages import expression_message, face_of, frame_of

Stream = list[tuple[str, Frame, Fit]]


def fit_of(frame: Frame, landmarks: np.ndarray, appearance: np.ndarray, failed: bool = False,
           reason: str = "", scheme: str = "ibug68") -> Fit:
    """The ``Fit`` the fitter would publish for ``frame``."""
    h = frame.header
    header = Header.now(h.stream_id, h.frame_index, "fitter", h.capture_time_ns, h.run_id)
    found = None if appearance is None or appearance.size == 0 else FitAppearance(
        appearance.astype(np.float32), np.zeros((2, 2), np.float32), 0.0, 5, not failed,
        np.zeros(0, np.uint8))
    return Fit(header, scheme, landmarks.astype(np.float32), np.zeros(4, np.float32),
               frame.width, frame.height, failed, reason, 0.0 if failed else 0.9,
               "cpu" if found is not None else "none", found)


def poser_stream(model_path: Path, jaffe_dir: Path, poser: str, repeats: int,
                 stream: str = "cam0", run: str = "") -> Stream:
    """Class, frame and fit of one poser's JAFFE faces, ``repeats`` times over as consecutive
    frames of one stream, fitted as the stack fits them."""
    samples = [s for s in load_jaffe(jaffe_dir).samples if s.poser == poser]
    observed = stack_observations(FittingModel.load(model_path), [s.load_image()
                                                                  for s in samples])
    out = []
    for i, (sample, obs) in enumerate(list(zip(samples, observed, strict=True)) * repeats):
        frame = Frame.from_array(Header.now(stream, i, "source", run_id=run), obs.image)
        out.append((sample.label, frame, fit_of(frame, obs.landmarks, obs.appearance,
                                                obs.fit_failed, obs.fit_reason)))
    return out


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
    with np.load(classifier_path, allow_pickle=False) as archive:
        arrays = {name: archive[name] for name in archive.files}
    header = json.loads(arrays["header"].tobytes()) | {"format_version": 1}
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), np.uint8)
    np.savez(tmp_path / "format1.npz", **arrays)
    none, why = load_classifier(str(tmp_path / "format1.npz"), None)
    assert none is None and "format version 1" in why and "retrain it" in why
    classifier, why = load_classifier(str(classifier_path), str(model_path))
    assert classifier is not None and why == ""


def test_every_frame_of_a_stream_is_classified_from_the_first(
    model_path: Path, classifier_path: Path, jaffe_dir: Path
) -> None:
    classifier, _ = load_classifier(str(classifier_path), str(model_path))
    assert classifier is not None
    recognise = ExpressionOperator(classifier, PIPELINE.expression.replace(hold=0))
    right = 0
    with Service("expression", BusOptions("cam0"), handle_signals=False) as svc:
        stream = poser_stream(model_path, jaffe_dir, "KA", 3)
        for label, frame, fit in stream:
            [found] = recognise(frame_of(fit), frame.image, [face_of(fit)])
            assert found.ok, found.reason
            message = expression_message(svc, fit, found)
            assert message.header.frame_index == fit.header.frame_index
            assert message.class_names == classifier.class_names and len(message.scores) == 7
            assert message.scores.dtype == np.float32 and not message.smoothed
            assert abs(float(message.scores.sum()) - 1.0) < 1e-5 and message.reason == ""
            right += message.label == label
        blank = np.zeros((240, 320), np.uint8)
        _, frame, _ = stream[0]
        none = fit_of(frame, np.zeros((0, 2)), np.zeros(0), True, "no face")
        [found] = recognise(frame_of(none), blank, [face_of(none)])
        message = expression_message(svc, none, found)
        assert message.label == "" and message.reason == "no face" and len(message.scores) == 0
        decoded = decode(encode(message), "expression")
        assert decoded.reason == "no face" and decoded.class_names == classifier.class_names
    assert right / len(stream) > 0.8  # training faces


def test_the_status_line_counts_the_reasons() -> None:
    counts = Unclassified()
    assert counts.status() == "every fit with an expression"
    counts.add("no face", 3)
    counts.add("face in profile: turned about 50 degrees (at most 35)", 4)
    counts.add("no face", 5)
    assert counts.status() == ("3 fits without expression: 2 no face, 1 face in profile; "
                             "last frame 5: no face")


def _start(bus: BusOptions, *args: str) -> subprocess.Popen[str]:
    env = os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO_ROOT)}
    return subprocess.Popen([sys.executable, "-m", "services", "service", "expression",
                             *options_argv(bus), *args], env=env, cwd=REPO_ROOT,
                            stderr=subprocess.PIPE, text=True)


def _stop(proc: subprocess.Popen[str]) -> str:
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    return err


def _expected(classifier: ExpressionClassifier, stream: Stream) -> dict[int, str]:
    """What the library's recogniser gives on the same fits and frames, with the service's
    label hold: the label, or "" for a frame without one."""
    recognise = ExpressionOperator(classifier, PIPELINE.expression)
    assert PIPELINE.expression.hold == STACK_HOLD
    labels = {}
    for _, frame, fit in stream:
        [found] = recognise(frame_of(fit), frame.image, [face_of(fit)])
        labels[fit.header.frame_index] = found.label or ""
    return labels


def test_the_service_pairs_each_fit_with_its_frame_and_counts_what_it_cannot_classify(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions], model_path: Path,
    classifier_path: Path, jaffe_dir: Path,
) -> None:
    stream = poser_stream(model_path, jaffe_dir, "KL", 3, peer.stream)
    _, frame, fit = stream[30]  # a frame without a face in the middle of the stream
    stream[30] = ("", frame, fit_of(frame, np.zeros((0, 2)), np.zeros(0), True, "no face"))
    expected = _expected(ExpressionClassifier.load(classifier_path), stream)
    expressions = peer.inbox(topic_key(peer.stream, "expression"), capacity=256,
                             kind="expression")
    statuses = peer.inbox(status_key(peer.stream, "expression"), capacity=64, kind="status")
    proc = _start(bus_pair[1], "--classifier", str(classifier_path), "--model", str(model_path))
    try:
        assert peer.wait_for_alive(["expression"], 60) == []  # subscribed: it may be sent to
        got: dict[int, object] = {}
        for k, (_, frame, fit) in enumerate(stream):
            first, second = (fit, frame) if k % 7 == 3 else (frame, fit)  # a fit may come first
            for message in (first, second):
                peer.put(message.key(), encode(message), MUST_ARRIVE)
            # Each pair answered before the next goes: a loaded machine slows the service
            # down but cannot make it drop a frame.
            while k not in got:
                item = expressions.get(60)
                assert item is not None, f"no expression of frame {k}"
                got[item.message.header.frame_index] = item.message
        # Its statuses count the fit without a face, once it has taken it.
        last = None
        while last is None or "no face" not in last.message:
            item = statuses.get(60)
            assert item is not None, f"no status counts the fit without a face: {last}"
            last = item.message
    finally:
        _stop(proc)
    assert {k: m.label for k, m in got.items()} == expected
    assert got[30].reason == "no face"
    assert last is not None and last.state == "running", last
    assert "1 no face" in last.message, last.message


def test_fits_of_another_landmark_scheme_make_the_service_degraded(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions], model_path: Path,
    classifier_path: Path, jaffe_dir: Path,
) -> None:
    _, frame, _ = poser_stream(model_path, jaffe_dir, "KA", 1, peer.stream)[0]
    statuses = peer.inbox(status_key(peer.stream, "expression"), capacity=64, kind="status")
    proc = _start(bus_pair[1], "--classifier", str(classifier_path))
    try:
        assert peer.wait_for_alive(["expression"], 60) == []  # subscribed: it may be sent to
        for message in (frame, fit_of(frame, np.full((58, 2), 100.0), np.zeros(3),
                                      scheme="imm58")):
            peer.put(message.key(), encode(message), MUST_ARRIVE)
        last = None
        while last is None or last.state != "degraded":
            item = statuses.get(60)
            assert item is not None, f"no degraded status: {last}"
            last = item.message
    finally:
        err = _stop(proc)
    assert last is not None and last.state == "degraded", last
    assert "not on imm58 fits with 58 landmarks" in last.message and last.rejected == 1
    assert "rejected input from fit" in err


@pytest.mark.parametrize("classifier", [None, "missing.npz"])
def test_without_a_classifier_the_service_runs_degraded_and_says_why(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions], classifier: str | None,
    tmp_path: Path,
) -> None:
    statuses = peer.inbox(status_key(peer.stream, "expression"), capacity=16, kind="status")
    args = [] if classifier is None else ["--classifier", str(tmp_path / classifier)]
    proc = _start(bus_pair[1], *args)
    why = "no expression classifier given" if classifier is None else "classifier file not found"
    try:
        assert peer.wait_for_alive(["expression"], 30) == []
        got = statuses.get(10.0)
        assert got is not None
        assert got.message.state == "degraded"
        assert why in got.message.message
    finally:
        err = _stop(proc)
    assert why in err
