"""Multi-class decisions: one-against-all, max-wins voting and the decision DAG."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.decomposition import PCA

from aamcore.expression.multiclass import dag_scores, ovo_scores, pair_index
from aamcore.expression.svm import SVMExpressionClassifier
from tests.aamcore.expression.feature_sets import FeatureSet


def _pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
    return np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])


def test_dag_follows_the_list_elimination_by_hand() -> None:
    positive, negative = _pairs(3)  # machines (0,1), (0,2), (1,2)
    index = pair_index(positive, negative, 3)
    # Root (0 vs 2): 2 wins, 0 leaves; then (1 vs 2): 1 wins.
    scores = dag_scores(np.array([[5.0, -1.0, 2.0]]), positive, index)
    np.testing.assert_allclose(scores, [[0.0, 1.0, 0.5]])
    # The (0,1) machine is never asked on that path: changing it changes nothing.
    np.testing.assert_array_equal(
        dag_scores(np.array([[-5.0, -1.0, 2.0]]), positive, index), scores
    )
    # Root: 0 wins, 2 leaves; then (0 vs 1): 1 wins.
    np.testing.assert_allclose(
        dag_scores(np.array([[-1.0, 3.0, 0.0]]), positive, index), [[0.5, 1.0, 0.0]]
    )


def test_dag_respects_the_machine_orientation() -> None:
    positive, negative = np.array([1]), np.array([0])  # one machine, positive side class 1
    index = pair_index(positive, negative, 2)
    np.testing.assert_allclose(dag_scores(np.array([[2.0]]), positive, index), [[0.0, 1.0]])


def test_ovo_votes_and_confidence_break_ties() -> None:
    positive, negative = _pairs(3)
    # Cycle: 0 beats 1, 2 beats 0, 1 beats 2: one vote each; class 2 is most confident.
    values = np.array([[0.1, -2.0, 0.1]])
    scores = ovo_scores(values, positive, negative, 3)
    np.testing.assert_allclose(np.round(scores), [[1.0, 1.0, 1.0]])
    assert np.argmax(scores) == 2


Fitted = tuple[SVMExpressionClassifier, SVMExpressionClassifier, np.ndarray, np.ndarray, np.ndarray]


@pytest.fixture(scope="module")
def fitted(five_posers: FeatureSet) -> Fitted:
    """OvO and DAG fitted on four posers, with features, labels and the training mask."""
    train = five_posers.posers != "KR"
    pca = PCA(0.95, svd_solver="full").fit(five_posers.features[train])
    X = pca.transform(five_posers.features)
    y = five_posers.labels
    ovo = SVMExpressionClassifier("ovo", C=8.0, gamma=0.125).fit(X[train], y[train])
    dag = SVMExpressionClassifier("dag", C=8.0, gamma=0.125).fit(X[train], y[train])
    return ovo, dag, X, y, train


def test_dag_agrees_with_ovo_majority_on_most_samples(fitted: Fitted) -> None:
    ovo, dag, X, _, _ = fitted
    agreement = np.mean(ovo.predict(X) == dag.predict(X))
    assert agreement >= 0.85, agreement


def test_dag_predicts_every_class(fitted: Fitted) -> None:
    _, dag, X, y, train = fitted
    predicted = dag.predict(X[train])
    assert set(predicted) == set(y)
    assert np.mean(predicted == y[train]) > 0.9  # training samples
    scores = dag.decision_scores(X)
    assert np.all(scores.max(axis=1) == 1.0)
    np.testing.assert_allclose(np.sort(scores, axis=1), np.tile(np.arange(7) / 6, (len(X), 1)))
