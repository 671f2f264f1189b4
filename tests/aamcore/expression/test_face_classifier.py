"""aamcore.expression.face_classifier: block weights, LDA and RBF SVM, numpy scores."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.discriminant_analysis import LinearDiscriminantAnalysis

from aamcore.expression.face_classifier import (
    CLASSIFIERS,
    BlockScaler,
    LinearModel,
    block_scale,
    fit_face_classifier,
)
from tests.aamcore.expression.feature_sets import FeatureSet

DIMS = {"shape": 136, "appearance": 4}
CLASSES = ("NE", "HA", "SU")


def blobs(n_per: int = 12, n_posers: int = 4, seed: int = 0) -> tuple[np.ndarray, ...]:
    """Separable classes in a (n, 140) 'shape + appearance' space, with posers."""
    rng = np.random.default_rng(seed)
    centres = rng.normal(0, 3, (len(CLASSES), 140))
    X, y, g = [], [], []
    for p in range(n_posers):
        for k, name in enumerate(CLASSES):
            X.append(centres[k] + rng.normal(0, 1, (n_per, 140)))
            y += [name] * n_per
            g += [f"P{p}"] * n_per
    return np.vstack(X), np.array(y), np.array(g)


def test_block_scale_gives_each_block_its_weight_not_its_length() -> None:
    X = np.random.default_rng(0).normal(0, 5, (50, 140))
    Z = BlockScaler(tuple(DIMS.items()), (("appearance", 2.0),)).fit_transform(X)
    shape_energy = np.sum(Z[:, :136] ** 2) / len(Z)
    appearance_energy = np.sum(Z[:, 136:] ** 2) / len(Z)
    assert shape_energy == pytest.approx(1.0) and appearance_energy == pytest.approx(4.0)
    with pytest.raises(ValueError, match="add up"):
        block_scale(np.ones(3), DIMS, {})
    with pytest.raises(ValueError, match="> 0"):
        block_scale(np.ones(140), DIMS, {"shape": 0.0})


@pytest.mark.parametrize("name", CLASSIFIERS)
def test_every_classifier_learns_separable_blobs(name: str) -> None:
    X, y, g = blobs()
    fitted = fit_face_classifier(X, y, g, DIMS, {"shape": 1.0}, name)
    assert set(fitted.classes) == set(CLASSES) and fitted.params["classifier"] == name
    assert np.mean(fitted.predict(X) == y) > 0.95
    assert fitted.scores(X).shape == (len(X), 3)
    with pytest.raises(ValueError, match="unknown classifier"):
        fit_face_classifier(X, y, g, DIMS, {}, "logreg")


def test_linear_scores_are_sklearn_decision_values() -> None:
    X, y, g = blobs()
    fitted = fit_face_classifier(X, y, g, DIMS, {}, "lda")
    Z = BlockScaler(tuple(DIMS.items())).fit_transform(X)
    lda = LinearDiscriminantAnalysis(solver="lsqr", shrinkage="auto").fit(Z, y)
    np.testing.assert_allclose(fitted.scores(X), lda.decision_function(Z), rtol=1e-8, atol=1e-8)


def test_two_classes_give_two_opposite_scores() -> None:
    X, y, g = blobs()
    keep = y != "SU"
    fitted = fit_face_classifier(X[keep], y[keep], g[keep], DIMS, {}, "lda")
    scores = fitted.scores(X[keep])
    np.testing.assert_allclose(scores[:, 0], -scores[:, 1])
    assert np.mean(fitted.predict(X[keep]) == y[keep]) > 0.95


def test_linear_model_checks_its_arrays() -> None:
    with pytest.raises(ValueError, match="need"):
        LinearModel(np.zeros(3), np.ones(3), np.zeros((2, 4)), np.zeros(2))
    with pytest.raises(ValueError, match="scale"):
        LinearModel(np.zeros(3), np.zeros(3), np.zeros((2, 3)), np.zeros(2))
    model = LinearModel(np.zeros(3), np.ones(3), np.eye(2, 3), np.zeros(2))
    back = LinearModel.from_arrays(model.to_arrays())
    assert back.feature_dim == 3 and back.n_classes == 2


def test_lda_on_real_hog_features_beats_chance_on_an_unseen_poser(five_posers: FeatureSet
                                                                   ) -> None:
    train = five_posers.posers != "KA"
    fitted = fit_face_classifier(five_posers.features[train], five_posers.labels[train],
                                 five_posers.posers[train], {"hog": 1836})
    rate = np.mean(fitted.predict(five_posers.features[~train]) == five_posers.labels[~train])
    assert rate > 0.4  # chance: 1/7
