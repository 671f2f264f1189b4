"""aamcore.expression.shrinkage_lda: scikit-learn's shrinkage LDA through the Woodbury identity."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.discriminant_analysis import LinearDiscriminantAnalysis

from aamcore.expression.shrinkage_lda import shrinkage_lda


def _data(n: int, d: int, k: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, d)) * rng.uniform(0.2, 3.0, d)
    y = np.array([f"c{i % k}" for i in range(n)])
    for j, c in enumerate(np.unique(y)):
        X[y == c, j % d] += 2.0
    return X, y


def _scores(X: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    classes, coef, intercept = shrinkage_lda(X, y)
    ours = X @ coef.T + intercept
    lda = LinearDiscriminantAnalysis(solver="lsqr", shrinkage="auto").fit(X, y)
    assert list(classes) == list(lda.classes_)
    theirs = lda.decision_function(X)
    if theirs.ndim == 1:  # two classes: scikit-learn keeps the difference of the two scores
        ours = ours[:, 1] - ours[:, 0]
    return ours, theirs


@pytest.mark.parametrize(("n", "d", "k"), [(70, 400, 7), (40, 300, 2), (300, 20, 5)])
def test_scores_are_scikit_learns(n: int, d: int, k: int) -> None:
    ours, theirs = _scores(*_data(n, d, k))
    np.testing.assert_allclose(ours, theirs, rtol=1e-7, atol=1e-7 * np.abs(theirs).max())


def test_constant_features_are_taken_as_scikit_learn_takes_them() -> None:
    X, y = _data(60, 200, 4, seed=1)
    X[:, :5] = 0.0
    X[:, 5:9] = 0.37  # constant but not zero: rounding leaves its deviations tiny, not zero
    X[y == "c1", 9] = 1.5  # constant in one class only
    ours, theirs = _scores(X, y)
    np.testing.assert_allclose(ours, theirs, rtol=1e-7, atol=1e-7 * np.abs(theirs).max())


def test_one_class_is_refused() -> None:
    X, _ = _data(10, 30, 1)
    with pytest.raises(ValueError, match="two classes"):
        shrinkage_lda(X, np.array(["a"] * 10))
