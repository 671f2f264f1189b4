"""Mapping features onto the unit hypersphere."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from aamcore.expression.hypersphere import HypersphereMap, to_unit_sphere
from tests.aamcore.expression.feature_sets import FeatureSet


def test_real_features_map_to_unit_norms(five_posers: FeatureSet) -> None:
    train = five_posers.posers != "KA"
    sphere = HypersphereMap().fit(five_posers.features[train])
    mapped = sphere.transform(five_posers.features[~train])
    np.testing.assert_allclose(np.linalg.norm(mapped, axis=1), 1.0, atol=1e-12)


def test_mean_and_scale_come_from_the_training_data_only() -> None:
    rng = np.random.default_rng(0)
    train = rng.normal(3.0, 2.0, size=(50, 4))
    sphere = HypersphereMap().fit(train)
    np.testing.assert_allclose(sphere.mean_, train.mean(axis=0))
    np.testing.assert_allclose(sphere.scale_, train.std(axis=0))
    test = rng.normal(size=(5, 4))
    expected = (test - train.mean(axis=0)) / train.std(axis=0)
    expected /= np.linalg.norm(expected, axis=1, keepdims=True)
    np.testing.assert_allclose(sphere.transform(test), expected)


def test_constant_feature_and_zero_row_do_not_divide_by_zero() -> None:
    train = np.array([[1.0, 5.0], [3.0, 5.0], [2.0, 5.0]])
    sphere = HypersphereMap().fit(train)
    out = sphere.transform(np.array([[2.0, 5.0], [4.0, 5.0]]))
    np.testing.assert_array_equal(out[0], [0.0, 0.0])
    np.testing.assert_allclose(out[1], [1.0, 0.0])


@settings(max_examples=50, deadline=None)
@given(arrays(np.float64, (6, 3), elements=st.floats(-1e3, 1e3)))
def test_nonzero_rows_always_get_unit_norm(X: np.ndarray) -> None:
    out = to_unit_sphere(X, np.zeros(3), np.ones(3))
    norms = np.linalg.norm(out, axis=1)
    nonzero = np.linalg.norm(X, axis=1) > 1e-9
    np.testing.assert_allclose(norms[nonzero], 1.0, atol=1e-9)
    assert np.all(np.isfinite(out))
