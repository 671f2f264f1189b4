"""RBF SVM expression classifier: schemes, tuning inside the training data, arrays."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.decomposition import PCA
from sklearn.svm import SVC

from aamcore.expression.hypersphere import HypersphereMap
from aamcore.expression.svm import SVMExpressionClassifier, SVMModel, tune_svm
from tests.aamcore.expression.feature_sets import FeatureSet

SMALL_C = 2.0 ** np.array([1, 5, 9])
SMALL_GAMMA = 2.0 ** np.array([-7, -3, 1])

Split = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
"""Training features, labels, posers; test features, labels."""


@pytest.fixture(scope="module")
def split(five_posers: FeatureSet) -> Split:
    """PCA features fitted on four posers; poser MK held out."""
    train = five_posers.posers != "MK"
    pca = PCA(0.95, svd_solver="full").fit(five_posers.features[train])
    X = pca.transform(five_posers.features)
    return (
        X[train],
        five_posers.labels[train],
        five_posers.posers[train],
        X[~train],
        (five_posers.labels[~train]),
    )


def test_ovo_matches_libsvm_max_wins(split: Split) -> None:
    X, y, _, X_test, _ = split
    ours = SVMExpressionClassifier("ovo", C=8.0, gamma=0.125).fit(X, y)
    sphere = HypersphereMap().fit(X)
    reference = SVC(C=8.0, gamma=0.125).fit(sphere.transform(X), y)
    agreement = np.mean(ours.predict(X_test) == reference.predict(sphere.transform(X_test)))
    assert agreement >= 0.95  # libsvm breaks vote ties by class index, we by confidence


@pytest.mark.parametrize("scheme", ["ova", "ovo", "dag"])
def test_tuned_svm_beats_chance_on_the_unseen_poser(split: Split, scheme: str) -> None:
    X, y, groups, X_test, y_test = split
    model = tune_svm(X, y, groups, scheme, SMALL_C, SMALL_GAMMA, inner_splits=2)
    assert model.C in SMALL_C and model.gamma in SMALL_GAMMA
    assert model.scheme == scheme
    assert np.mean(model.predict(X_test) == y_test) >= 2 / 7  # chance is 1/7
    scores = model.decision_scores(X_test)
    assert scores.shape == (len(X_test), 7)
    np.testing.assert_array_equal(model.predict(X_test), model.classes_[scores.argmax(axis=1)])


def test_model_rebuilds_from_its_arrays(split: Split) -> None:
    X, y, _, X_test, _ = split
    model = SVMExpressionClassifier("dag", C=4.0, gamma=0.5).fit(X, y).model_
    rebuilt = SVMModel.from_arrays(model.to_arrays(), "dag", 7)
    np.testing.assert_array_equal(rebuilt.scores(X_test), model.scores(X_test))
    with pytest.raises(ValueError, match="needs 7 machines"):
        SVMModel.from_arrays(model.to_arrays(), "ova", 7)
    positive = model.machines.positive.copy()
    positive[0] = 9  # no such class
    with pytest.raises(ValueError, match="class pairs"):
        SVMModel.from_arrays(model.to_arrays() | {"positive": positive}, "dag", 7)


def test_bad_arguments_are_refused(split: Split) -> None:
    X, y, groups, _, _ = split
    with pytest.raises(ValueError, match="scheme"):
        SVMExpressionClassifier("crammer").fit(X, y)
    with pytest.raises(ValueError, match="2 posers"):
        tune_svm(X, y, np.full(len(y), "KA"), "ova", SMALL_C, SMALL_GAMMA)
