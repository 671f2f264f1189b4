"""Fisher LDA + Mahalanobis classification on real JAFFE features."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import binomtest
from sklearn.decomposition import PCA
from sklearn.discriminant_analysis import LinearDiscriminantAnalysis

from aamcore.expression.lda import FisherMahalanobis, MahalanobisModel, pooled_covariance
from aamcore.expression.thesis_classifiers import lda_mahalanobis_spec
from tests.aamcore.expression.feature_sets import FeatureSet

Features = tuple[np.ndarray, np.ndarray]
"""PCA features (n, d) and labels (n,)."""


@pytest.fixture(scope="module")
def features(jaffe_features: FeatureSet) -> Features:
    """PCA features (95 % variance) of all JAFFE crops, with labels."""
    X = PCA(0.95, svd_solver="full").fit_transform(jaffe_features.features)
    return X, jaffe_features.labels


@pytest.mark.parametrize("solver", ["svd", "eigen"])
def test_projection_reproduces_sklearn_transform(features: Features, solver: str) -> None:
    X, y = features
    model = FisherMahalanobis(n_components=4, solver=solver).fit(X, y)
    reference = LinearDiscriminantAnalysis(solver=solver, n_components=4).fit(X, y)
    np.testing.assert_allclose(model.transform(X), reference.transform(X), atol=1e-9)
    assert model.transform(X).shape == (len(X), 4)


def test_mahalanobis_uses_pooled_within_class_covariance(features: Features) -> None:
    X, y = features
    model = FisherMahalanobis().fit(X, y)
    Z = model.transform(X)
    y_idx = np.searchsorted(model.classes_, y)
    centroids = np.stack([Z[y == c].mean(axis=0) for c in model.classes_])
    covariance = pooled_covariance(Z, y_idx, centroids)
    # Independent computation of eq 9.9 for one sample and class.
    diff = Z[0] - centroids[2]
    expected = diff @ np.linalg.solve(covariance, diff)
    assert model.mahalanobis(X[:1])[0, 2] == pytest.approx(expected, rel=1e-8)
    scatter = sum(np.cov(Z[y == c].T, bias=True) * np.sum(y == c) for c in model.classes_)
    np.testing.assert_allclose(covariance, scatter / (len(X) - len(model.classes_)), atol=1e-10)


def test_scores_probabilities_and_prediction_agree(features: Features) -> None:
    X, y = features
    model = FisherMahalanobis(n_components=5).fit(X, y)
    scores = model.decision_scores(X)
    proba = model.predict_proba(X)
    assert scores.shape == proba.shape == (len(X), 7)
    np.testing.assert_allclose(proba.sum(axis=1), 1.0)
    np.testing.assert_array_equal(np.argmax(proba, axis=1), np.argmax(scores, axis=1))
    np.testing.assert_array_equal(model.predict(X), model.classes_[np.argmax(scores, axis=1)])


def test_model_rebuilds_from_its_arrays(features: Features) -> None:
    X, y = features
    model = FisherMahalanobis(n_components=3).fit(X, y).model_
    rebuilt = MahalanobisModel.from_arrays(model.to_arrays())
    np.testing.assert_array_equal(rebuilt.scores(X), model.scores(X))
    arrays = model.to_arrays() | {"precision": np.eye(2)}
    with pytest.raises(ValueError, match="precision"):
        MahalanobisModel.from_arrays(arrays)


def test_bad_inputs_are_refused(features: Features) -> None:
    X, y = features
    with pytest.raises(ValueError, match="solver"):
        FisherMahalanobis(solver="lsqr").fit(X, y)
    with pytest.raises(ValueError, match="2 classes"):
        FisherMahalanobis().fit(X[:10], np.array(["HA"] * 10))
    model = FisherMahalanobis().fit(X, y)
    with pytest.raises(ValueError, match="features"):
        model.predict(X[:, :5])


def test_beats_chance_leave_one_poser_out(five_posers: FeatureSet) -> None:
    fit = lda_mahalanobis_spec(n_trials=5).fit
    X, y, posers = five_posers.features, five_posers.labels, five_posers.posers
    predicted = np.empty_like(y)
    for poser in np.unique(posers):
        test = posers == poser
        pca = PCA(0.95, svd_solver="full").fit(X[~test])  # fitted inside the fold
        model = fit(pca.transform(X[~test]), y[~test], posers[~test])
        predicted[test] = model.predict(pca.transform(X[test]))
    n = len(y)
    correct = int(np.sum(predicted == y))
    assert correct / n >= 0.30  # chance is 1/7
    assert binomtest(correct, n, 1 / 7, alternative="greater").pvalue < 1e-6
