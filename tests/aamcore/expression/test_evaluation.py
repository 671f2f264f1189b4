"""aamcore.expression.evaluation: results over every face (refused ones counted wrong) and the
thesis's classifiers."""

from __future__ import annotations

import json

import numpy as np
import pytest

from aamcore.expression.evaluation import (
    NOT_CLASSIFIED,
    EvaluationResult,
    default_classifiers,
    lda_mahalanobis_spec,
)
from tests.aamcore.expression.feature_sets import FeatureSet


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


def test_the_thesis_classifiers_fit_inside_the_training_data(five_posers: FeatureSet) -> None:
    specs = default_classifiers(n_trials=2, C_grid=np.array([8.0]), gamma_grid=np.array([0.5]))
    assert [s.name for s in specs] == ["LDA+Mahalanobis", "SVM OvA", "SVM OvO", "SVM DAG"]
    X = five_posers.features[:, :50]
    train = five_posers.posers != "KA"
    for spec in specs:
        model = spec.fit(X[train], five_posers.labels[train], five_posers.posers[train])
        assert set(model.predict(X[~train])) <= set(five_posers.labels)
    lda = lda_mahalanobis_spec(n_trials=2).fit(X, five_posers.labels, five_posers.posers)
    assert 1 <= lda.n_components <= 6
