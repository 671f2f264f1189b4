"""aamcore.evaluation.expression_results: scores over every face, refused ones apart."""

from __future__ import annotations

import json

import numpy as np
import pytest

from aamcore.evaluation.expression_results import NOT_CLASSIFIED, EvaluationResult


def test_result_summaries_are_consistent() -> None:
    y_true = np.array(["NE", "NE", "HA", "HA", "SU", "SU", "SU", "FE"])
    y_pred = np.array(["NE", "HA", "HA", "HA", "SU", "FE", "SU", "NE"])
    result = EvaluationResult(
        "x", "f", ("NE", "HA", "SU", "FE", "DI"), y_true, y_pred, np.array(["A"] * 8)
    )
    assert result.columns == result.class_names and result.n == 8
    counts = result.confusion()
    assert counts[0].tolist() == [1, 1, 0, 0, 0] and counts[2].tolist() == [0, 0, 2, 1, 0]
    percent = result.confusion_percent()
    np.testing.assert_allclose(percent[:4].sum(axis=1), 100.0)
    np.testing.assert_array_equal(percent[4], 0.0)  # no disgust sample
    assert result.overall_rate == pytest.approx(5 / 8)
    np.testing.assert_allclose(result.per_class_rates(), [0.5, 1.0, 2 / 3, 0.0, 0.0])
    summary = json.loads(json.dumps(result.to_dict()))
    assert summary["per_class_rates"]["SU"] == pytest.approx(2 / 3)


def test_refused_faces_count_wrong_and_get_their_own_column() -> None:
    y_true = np.array(["NE", "NE", "HA", "HA"])
    y_pred = np.array(["NE", NOT_CLASSIFIED, "HA", NOT_CLASSIFIED])
    result = EvaluationResult("x", "f", ("NE", "HA"), y_true, y_pred, np.array(["A"] * 4),
                              refused=["a.tiff: no face", "b.tiff: face in profile"])
    assert result.columns == ("NE", "HA", NOT_CLASSIFIED)
    assert result.confusion().tolist() == [[1, 0, 1], [0, 1, 1]]
    np.testing.assert_allclose(result.confusion_percent(), [[50, 0, 50], [0, 50, 50]])
    assert result.overall_rate == 0.5 and result.per_class_rates().tolist() == [0.5, 0.5]
    assert result.to_dict()["refused"] == result.refused


def test_labelled_faces_are_scored_apart_and_every_class_counts_alike() -> None:
    y_true = np.array(["NE"] * 8 + ["HA", "HA", "SU", "SU"])
    y_pred = np.array(["NE"] * 7 + [NOT_CLASSIFIED, "NE", "HA", "NE", NOT_CLASSIFIED])
    result = EvaluationResult("x", "f", ("NE", "HA", "SU", "FE"), y_true, y_pred,
                              np.array(["A"] * 12))
    assert result.share_labelled == pytest.approx(10 / 12)
    assert result.labelled_accuracy == pytest.approx(8 / 10)
    assert result.recalls() == {"NE": (7, 7), "HA": (1, 2), "SU": (0, 1), "FE": (0, 0)}
    # Saying "neutral" to most faces does not make a good mean of the classes' recalls.
    assert result.mean_recall == pytest.approx((1 + 0.5 + 0) / 3)
    assert result.missing_classes == ["FE"]
    summary = json.loads(json.dumps(result.to_dict()))
    assert summary["missing_classes"] == ["FE"] and summary["recalls"]["HA"] == [1, 2]
