"""aamcore.expression.recogniser: a stream of fits and frames, warm-up, smoothing, bad fits."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aamcore.expression import AAMMismatchError, ExpressionClassifier
from aamcore.expression.faces import LabelledFaces
from aamcore.expression.recogniser import ExpressionRecogniser, LabelHold, Smoother
from tests.aamcore.expression.synthetic_faces import expression_observation, stream_classifier


def test_smoother_averages_consecutive_frames_and_restarts_after_a_gap() -> None:
    smoother = Smoother(3)
    assert smoother.add(0, np.array([1.0, 0.0]))[1] is False
    mean, smoothed = smoother.add(1, np.array([0.0, 1.0]))
    assert smoothed and np.allclose(mean, [0.5, 0.5])
    mean, smoothed = smoother.add(5, np.array([0.0, 3.0]))  # frames 2-4 were not classified
    assert not smoothed and np.allclose(mean, [0.0, 3.0])
    with pytest.raises(ValueError):
        Smoother(0)


def _recognise(recogniser: ExpressionRecogniser, index: int, kind: str, person: float = 0.05):
    obs = expression_observation(kind, person)
    return recogniser.recognise(index, obs.image, obs.landmarks, obs.appearance)


def test_no_label_while_the_reference_is_learned_then_smoothed_scores() -> None:
    classifier = stream_classifier(min_count=3)
    recogniser = ExpressionRecogniser(classifier, smooth=2)
    first = _recognise(recogniser, 0, "NE")
    assert not first.ok and first.scores is None and first.class_names == classifier.class_names
    assert first.reason == "learning the face's reference: 1 of 3 samples"
    assert not _recognise(recogniser, 1, "HA").ok
    third = _recognise(recogniser, 2, "SU")
    assert third.ok and third.label == "SU" and not third.smoothed and third.reason == ""
    fourth = _recognise(recogniser, 3, "SU")
    assert fourth.smoothed and fourth.label == "SU"
    raw = recogniser.pipeline.process(expression_observation("SU", 0.05)).scores
    assert raw is not None and fourth.scores is not None and fourth.scores.shape == raw.shape


def test_a_frame_index_that_goes_back_starts_the_stream_afresh() -> None:
    recogniser = ExpressionRecogniser(stream_classifier(min_count=2))
    _recognise(recogniser, 10, "NE")
    assert _recognise(recogniser, 11, "HA").ok
    again = _recognise(recogniser, 0, "HA")  # a new run of the source
    assert not again.ok and again.reason.startswith("learning the face's reference: 1 of 2")


def test_no_face_and_fits_of_another_model() -> None:
    recogniser = ExpressionRecogniser(stream_classifier())
    image = np.zeros((240, 320), np.uint8)
    none = recogniser.recognise(0, image, None, None, True, "no face")
    assert not none.ok and none.reason == "no face"
    obs = expression_observation("NE", 0.0)
    with pytest.raises(AAMMismatchError, match="not on imm58 fits with 58 landmarks"):
        recogniser.recognise(1, obs.image, np.zeros((58, 2)), obs.appearance, scheme="imm58")
    # A shape-only pipeline does not read the appearance: a fit of any length is taken.
    assert "appearance" not in recogniser.classifier.pipeline.features.blocks
    taken = recogniser.recognise(2, obs.image, obs.landmarks, np.zeros(7))
    assert taken.reason != "no face"


def test_a_stream_of_one_jaffe_posers_faces_is_recognised(
    classifier_path: Path, jaffe: LabelledFaces
) -> None:
    """Every frame is labelled from the first (the person-independent model decides until the
    stream's reference is ready, then the relative model fused with it), with
    probabilities."""
    classifier = ExpressionClassifier.load(classifier_path)
    assert classifier.absolute is not None and classifier.temperature > 0
    recogniser = ExpressionRecogniser(classifier)
    faces = np.tile(np.flatnonzero(jaffe.posers == "KA"), 4)
    right, bases = 0, []
    for k, i in enumerate(faces):
        obs = jaffe.observations[i]
        found = recogniser.recognise(k, obs.image, obs.landmarks, obs.appearance, obs.fit_failed)
        assert found.ok, found.reason
        assert found.scores is not None and np.isclose(found.scores.sum(), 1.0)
        right += found.label == jaffe.labels[i]
        bases.append(found.basis)
    assert bases[0] == "absolute" and set(bases) <= {"absolute", "relative"}
    assert right / len(faces) > 0.8  # training faces


def test_a_held_label_changes_only_after_the_new_one_leads_for_a_few_frames() -> None:
    hold = LabelHold(2)
    ha, su = np.array([0.1, 0.8, 0.1]), np.array([0.1, 0.2, 0.7])
    assert hold.add(ha) == 1
    assert hold.add(su) == 1  # one frame of SU: HA still shown
    assert hold.add(ha) == 1
    assert hold.add(su) == 1 and hold.add(su) == 2  # two in a row: SU
    assert LabelHold(0).add(su) == 2
    with pytest.raises(ValueError):
        LabelHold(-1)


def test_the_recogniser_holds_labels_and_a_frame_without_one_forgets_the_label() -> None:
    recogniser = ExpressionRecogniser(stream_classifier(min_count=5, absolute=True), hold=2)
    first = _recognise(recogniser, 0, "HA")
    assert first.label == "HA" and first.basis == "absolute"
    flicker = _recognise(recogniser, 1, "SU")
    assert flicker.label == "HA" and flicker.smoothed  # held
    image = np.zeros((240, 320), np.uint8)
    assert not recogniser.recognise(2, image, None, None, True, "no face").ok
    assert _recognise(recogniser, 3, "SU").label == "SU"  # nothing held after the gap
