"""aamcore.fitting.failure: the tests of the appearance and the learned quality score."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aamcore.fitting.failure import FAILURE_TESTS, FailureTest, QualityTest


def test_appearance_tests_and_the_quality_kind() -> None:
    variances = np.ones(10)
    points = np.array([[0.0, 0.0], [10.0, 0.0], [5.0, 10.0]])
    far = np.full(10, 5.0)
    assert "3 sigma" in FailureTest(variances, "eq7.2")(far, points)
    assert "chi-square" in FailureTest(variances, "chi2")(far, points)
    quality = FailureTest(variances, "quality")
    assert quality(far, points) == "" and quality(np.zeros(0), points) == ""
    assert quality(np.zeros(0), points[:, :1].repeat(2, 1) * 0) == "degenerate shape"
    assert quality(np.zeros(0), points * np.nan) == "non-finite parameters"
    assert set(FAILURE_TESTS) == {"auto", "chi2", "eq7.2", "quality"}
    for kind in ("auto", "newton"):
        with pytest.raises(ValueError, match="unknown failure test"):
            FailureTest(variances, kind)


def test_quality_threshold_and_confidence() -> None:
    test = QualityTest(-2.5)
    assert test.reason(-3.0) == "" and test.reason(-2.5) == ""
    assert "above -2.50" in test.reason(-2.0) and "predicted NME" in test.reason(-2.0)
    assert test.reason(math.nan) == "no quality score"
    assert "above" in test.reason(math.inf)
    assert test.confidence(-2.5) == pytest.approx(0.05, abs=0.005)
    assert test.confidence(-3.0) == pytest.approx(0.5)
    assert test.confidence(-4.0) > 0.99
    assert test.confidence(math.inf) == 0.0 and test.confidence(math.nan) == 0.0
    scores = np.linspace(-6, 2, 50)
    confidences = [test.confidence(s) for s in scores]
    assert all(0.0 <= c <= 1.0 for c in confidences)
    assert confidences == sorted(confidences, reverse=True)
    with pytest.raises(ValueError, match="not finite"):
        QualityTest(math.inf)
