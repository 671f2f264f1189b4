"""Binary RBF machines as arrays, checked against scikit-learn's SVC."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.decomposition import PCA
from sklearn.svm import SVC

from aamcore.expression.hypersphere import HypersphereMap
from aamcore.expression.kernel_machines import (
    REST,
    RBFMachines,
    fit_one_against_all,
    fit_pairwise,
)
from tests.aamcore.expression.feature_sets import FeatureSet

Features = tuple[np.ndarray, np.ndarray]


@pytest.fixture(scope="module")
def unit_features(five_posers: FeatureSet) -> Features:
    """Unit-norm PCA features (n, d) and class indices (n,) of five posers."""
    X = PCA(0.95, svd_solver="full").fit_transform(five_posers.features)
    _, y_idx = np.unique(five_posers.labels, return_inverse=True)
    return HypersphereMap().fit_transform(X), y_idx


def test_pairwise_machines_match_libsvm_decision_values(unit_features: Features) -> None:
    U, y = unit_features
    machines = fit_pairwise(U, y, 7, C=8.0, gamma=0.5)
    reference = SVC(C=8.0, gamma=0.5, decision_function_shape="ovo").fit(U, y)
    assert machines.n_machines == 21
    np.testing.assert_allclose(
        machines.decision_values(U), reference.decision_function(U), atol=1e-9
    )
    pairs = list(zip(machines.positive.tolist(), machines.negative.tolist(), strict=True))
    assert pairs == [(i, j) for i in range(7) for j in range(i + 1, 7)]


def test_one_against_all_machines_match_binary_svcs(unit_features: Features) -> None:
    U, y = unit_features
    machines = fit_one_against_all(U, y, 7, C=4.0, gamma=0.25)
    assert machines.n_machines == 7 and np.all(machines.negative == REST)
    values = machines.decision_values(U)
    for c in (0, 3, 6):
        svc = SVC(C=4.0, gamma=0.25).fit(U, (y == c).astype(int))
        np.testing.assert_allclose(values[:, c], svc.decision_function(U), atol=1e-9)


def test_arrays_round_trip_and_inconsistent_arrays_are_refused(unit_features: Features) -> None:
    U, y = unit_features
    machines = fit_pairwise(U, y, 7, C=1.0, gamma=1.0)
    rebuilt = RBFMachines.from_arrays(machines.to_arrays())
    np.testing.assert_array_equal(rebuilt.decision_values(U), machines.decision_values(U))
    arrays = machines.to_arrays()
    with pytest.raises(ValueError, match="offsets"):
        RBFMachines.from_arrays(arrays | {"offsets": arrays["offsets"][:-1]})
    with pytest.raises(ValueError, match="gamma"):
        RBFMachines.from_arrays(arrays | {"gamma": np.asarray(-1.0)})
    with pytest.raises(ValueError, match="dual_coef"):
        RBFMachines.from_arrays(arrays | {"dual_coef": arrays["dual_coef"][:-1]})
