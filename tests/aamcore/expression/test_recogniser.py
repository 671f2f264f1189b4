"""aamcore.expression.recogniser: classifying a stream of fits, scores smoothed over frames."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aamcore.expression import ExpressionClassifier
from aamcore.expression.recogniser import ExpressionRecogniser, Smoother


def test_smoother_averages_consecutive_frames_and_restarts_after_a_gap() -> None:
    smoother = Smoother(3)
    assert smoother.add(0, np.array([1.0, 0.0]))[1] is False
    mean, smoothed = smoother.add(1, np.array([0.0, 1.0]))
    assert smoothed and np.allclose(mean, [0.5, 0.5])
    mean, smoothed = smoother.add(5, np.array([0.0, 3.0]))  # frames 2-4 had no good fit
    assert not smoothed and np.allclose(mean, [0.0, 3.0])
    with pytest.raises(ValueError):
        Smoother(0)


def test_a_recogniser_smooths_consecutive_frames_only(classifier_path: Path) -> None:
    classifier = ExpressionClassifier.load(classifier_path)
    recogniser = ExpressionRecogniser(classifier, smooth=3)
    rng = np.random.default_rng(0)
    c = [rng.normal(0, 0.5, classifier.feature_dim) for _ in range(3)]
    first = recogniser.recognise(0, c[0])
    assert not first.smoothed and first.label in classifier.class_names
    second = recogniser.recognise(1, c[1])
    expected = (classifier.classify(c[0])[1] + classifier.classify(c[1])[1]) / 2
    assert second.smoothed and np.allclose(second.scores, expected)
    assert not recogniser.recognise(7, c[2]).smoothed  # a gap: the average starts again
    with pytest.raises(ValueError):
        recogniser.recognise(8, np.zeros(classifier.feature_dim + 1))
