"""aamcore.expression.network: the small network of face-feature vectors, scored by numpy."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.expression.network import NetworkModel, fit_network

DIMS = {"hog": 4, "appearance": 2}


def rings(n: int = 400, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Three classes no line separates: the radius of the first two features decides."""
    rng = np.random.default_rng(seed)
    X = rng.normal(0, 1, (n, sum(DIMS.values())))
    radius = np.hypot(X[:, 0], X[:, 1])
    y = np.where(radius < 0.8, "NE", np.where(radius < 1.6, "HA", "SU"))
    return X, y


def test_the_network_learns_classes_a_line_cannot_separate() -> None:
    X, y = rings()
    fitted = fit_network(X[:300], y[:300], DIMS, hidden=32, alpha=1e-3, epochs=200)
    assert fitted.kind == "network" and fitted.classes == ("HA", "NE", "SU")
    assert np.mean(fitted.predict(X[300:]) == y[300:]) > 0.7  # a line: about 0.4
    again = fit_network(X[:300], y[:300], DIMS, hidden=32, alpha=1e-3, epochs=200)
    np.testing.assert_array_equal(again.scores(X), fitted.scores(X))  # seeded


def test_a_stored_network_scores_as_the_trained_one() -> None:
    X, y = rings(90)
    model = fit_network(X, y, DIMS, hidden=8, epochs=20).model
    assert isinstance(model, NetworkModel) and model.feature_dim == X.shape[1]
    back = NetworkModel.from_arrays(model.to_arrays())
    np.testing.assert_array_equal(back.scores(X), model.scores(X))
    offset = np.array([1.0, -2.0, 0.5])
    np.testing.assert_allclose(model.shifted(offset).scores(X), model.scores(X) + offset)
    with pytest.raises(ValueError):
        NetworkModel.from_arrays(model.to_arrays() | {"coef": np.zeros((3, 5))})


def test_two_classes_score_as_two_columns() -> None:
    X, y = rings(120)
    y = np.where(y == "NE", "NE", "HA")
    fitted = fit_network(X, y, DIMS, hidden=16, epochs=50)
    assert fitted.scores(X).shape == (120, 2) and fitted.classes == ("HA", "NE")


def test_a_rare_class_weighs_as_much_as_a_frequent_one() -> None:
    X, y = rings()
    rare = (y != "NE") | (np.arange(len(y)) % 4 == 0)  # a quarter of the neutral faces
    fitted = fit_network(X[rare], y[rare], DIMS, hidden=32, alpha=1e-3, epochs=200)
    neutral = y == "NE"
    assert np.mean(fitted.predict(X[neutral & ~rare]) == "NE") > 0.5


def test_an_ensemble_is_one_network_scoring_its_members_mean() -> None:
    X, y = rings()
    members = [fit_network(X[:300], y[:300], DIMS, hidden=16, epochs=60, seed=s)
               for s in (3, 4, 5)]
    ensemble = fit_network(X[:300], y[:300], DIMS, hidden=16, epochs=60, seed=3, seeds=3)
    assert isinstance(ensemble.model, NetworkModel)
    assert ensemble.model.hidden_coef.shape == (X.shape[1], 48)
    mean = np.mean([m.scores(X) for m in members], axis=0)
    np.testing.assert_allclose(ensemble.scores(X), mean, rtol=1e-4, atol=1e-4)
    # the members differ, so the mean is not any one of them
    assert np.abs(members[0].scores(X) - mean).max() > 1e-2
    with pytest.raises(ValueError, match="seeds"):
        fit_network(X, y, DIMS, seeds=0)
