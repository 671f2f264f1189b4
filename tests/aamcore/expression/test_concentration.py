"""The k-means concentration metric (eq 9.8) and the choice of Fisher directions."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.decomposition import PCA

from aamcore.expression.concentration import (
    choose_n_components,
    cluster_table,
    concentration_metric,
    concentration_study,
)
from tests.aamcore.expression.feature_sets import FeatureSet


def test_ideal_table_9_1_scores_n_classes_times_n_subjects() -> None:
    n_s = 21
    assert concentration_metric(n_s * np.eye(7, dtype=int)) == 7 * n_s


def test_spread_classes_score_lower_than_concentrated_ones() -> None:
    concentrated = np.array([[10, 0, 0], [0, 9, 1], [1, 0, 9]])
    uniform = np.array([[4, 3, 3], [3, 4, 3], [3, 3, 4]])
    assert concentration_metric(concentrated) == 10 + 9 + 9
    assert concentration_metric(uniform) == 3
    assert concentration_metric(concentrated) > concentration_metric(uniform)


def test_cluster_table_counts_class_cluster_pairs() -> None:
    y_idx = np.array([0, 0, 1, 1, 1, 2])
    clusters = np.array([2, 2, 0, 1, 0, 1])
    expected = np.array([[0, 0, 2], [2, 1, 0], [0, 1, 0]])
    np.testing.assert_array_equal(cluster_table(y_idx, clusters, 3), expected)


def test_study_on_real_features(jaffe_features: FeatureSet) -> None:
    X = PCA(0.95, svd_solver="full").fit_transform(jaffe_features.features)
    study = concentration_study(X, jaffe_features.labels, n_trials=6, random_state=3)
    np.testing.assert_array_equal(study.candidates, np.arange(1, 7))
    assert study.metrics.shape == (6, 6)
    # Each class row sums to its size (about 30), so a row scores at most its size.
    assert np.all(study.metrics > 0) and np.all(study.metrics <= len(X))
    assert study.histogram().sum() == 6
    assert study.best in study.best_per_trial()
    assert choose_n_components(X, jaffe_features.labels, n_trials=6, random_state=3) == study.best


def test_separable_classes_concentrate_on_the_discriminant_direction() -> None:
    rng = np.random.default_rng(0)
    y = np.repeat(np.arange(3), 40)
    X = rng.normal(size=(120, 5))
    X[:, 0] += 12.0 * y  # classes far apart on one axis only
    study = concentration_study(X, y, n_trials=5)
    assert study.metrics[:, 0].min() >= 3 * 40 - 6  # nearly ideal with one direction


def test_bad_arguments_are_refused() -> None:
    X = np.random.default_rng(1).normal(size=(30, 4))
    y = np.repeat(np.arange(3), 10)
    with pytest.raises(ValueError, match="candidates"):
        concentration_study(X, y, candidates=[0, 1])
    with pytest.raises(ValueError, match="n_trials"):
        concentration_study(X, y, n_trials=0)
    with pytest.raises(ValueError, match="2 classes"):
        concentration_study(X, np.zeros(30))
