"""aamcore.expression.learning: the person-independent and relative models, their out-of-fold
temperatures and their fusion."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.expression.calibration import softmax
from aamcore.expression.face_classifier import fit_logistic
from aamcore.expression.learning import Recipe, fuse, learn, out_of_fold, person_references
from tests.aamcore.expression.feature_sets import FeatureSet


def test_both_models_learn_the_faces_of_people_they_never_saw(five_posers: FeatureSet) -> None:
    X, y, people = five_posers.features, five_posers.labels, five_posers.posers
    sets = np.full(len(y), "jaffe")
    train = people != "KA"
    learned = learn(X[train], y[train], people[train], sets[train], {"hog": X.shape[1]},
                    Recipe(folds=2))
    assert learned.relative is not None and learned.relative.classes == learned.absolute.classes
    assert learned.counts == {"absolute": int(train.sum()), "relative": int(train.sum())}
    for t in (learned.absolute_temperature, learned.temperature, learned.fused_temperature):
        assert 0.01 < t < 100.0
    test = ~train
    R = person_references(X[test], people[test], 3)[0]
    fused = learned.fused_probabilities(X[test], R)
    np.testing.assert_allclose(fused.sum(axis=1), 1.0)
    classes = np.array(learned.absolute.classes)
    chance = 1.0 / len(classes)
    # A poser never seen, her faces one session: well above chance (any recipe's model).
    assert np.mean(classes[fused.argmax(axis=1)] == y[test]) > 2 * chance


def test_each_person_is_scored_by_a_model_that_never_saw_them(five_posers: FeatureSet) -> None:
    X, y, people = five_posers.features, five_posers.labels, five_posers.posers
    seen: list[set[str]] = []

    def fit(rows: np.ndarray):
        seen.append(set(people[rows]))
        return fit_logistic(X[rows], y[rows], {"hog": X.shape[1]})

    scores = out_of_fold(fit, tuple(sorted(set(y))), X, y, people, folds=5)
    assert scores.shape == (len(y), 7) and [len(s) for s in seen] == [4] * 5
    assert set.union(*seen) == set(people)


def test_references_are_medians_of_people_with_enough_faces() -> None:
    X = np.array([[1.0], [3.0], [8.0], [10.0], [20.0]])
    R, has = person_references(X, np.array(["a", "a", "a", "b", "b"]), 3)
    assert has.tolist() == [True, True, True, False, False]
    np.testing.assert_allclose(R[:3, 0], 3.0)
    neutral = np.array([True, True, False, True, False])  # 8 smiles: not the reference
    R, has = person_references(X, np.array(["a", "a", "a", "b", "b"]), 1, neutral)
    assert has.all() and R[:, 0].tolist() == [2.0, 2.0, 2.0, 10.0, 10.0]


def test_a_network_offset_for_people_it_never_saw(five_posers: FeatureSet) -> None:
    X, y, people = five_posers.features, five_posers.labels, five_posers.posers
    sets = np.full(len(y), "jaffe")
    train = people != "KA"
    recipe = Recipe(folds=2, learner="network", hidden=32, epochs=40, class_biases=True,
                    min_neutral=0.2, min_reference_faces=1)
    learned = learn(X[train], y[train], people[train], sets[train], {"hog": X.shape[1]},
                    recipe)
    assert learned.absolute.kind == "network" and learned.min_neutral == 0.2
    assert len(learned.absolute.params["class_biases"]) == 7
    assert learned.relative is not None and 0 < learned.counts["relative"] <= train.sum()
    classes = np.array(learned.absolute.classes)
    fresh = classes[learned.absolute_probabilities(X[~train]).argmax(axis=1)]
    assert np.mean(fresh == y[~train]) > 2 / 7  # a poser never seen, each face alone
    with pytest.raises(ValueError, match="learner"):
        Recipe(learner="forest")


def test_the_fused_score_weighs_the_absolute_model() -> None:
    rel, ab = np.array([[2.0, 0.0, 0.0]]), np.array([[0.0, 3.0, 0.0]])
    np.testing.assert_allclose(fuse(rel, ab, 1.0, 1.0, 0.0), softmax(rel))
    assert fuse(rel, ab, 1.0, 1.0, 0.25).argmax() == 0
    assert fuse(rel, ab, 1.0, 1.0, 1.0).argmax() == 1


def test_what_cannot_be_learned_is_refused_or_left_out(five_posers: FeatureSet) -> None:
    X, y, people = five_posers.features, five_posers.labels, five_posers.posers
    sets = np.full(len(y), "jaffe")
    with pytest.raises(ValueError, match="two classes or more"):
        learn(X[:3], np.array(["HA"] * 3), people[:3], sets[:3], {"hog": X.shape[1]})
    alone = learn(X, y, people, sets, {"hog": X.shape[1]}, Recipe(min_reference_faces=1000))
    assert alone.relative is None and alone.counts["relative"] == 0
    for bad in ({"C": 0.0}, {"absolute_weight": -1.0}, {"folds": 1}):
        with pytest.raises(ValueError):
            Recipe(**bad)  # type: ignore[arg-type]


def test_threads_learn_the_same_models(five_posers: FeatureSet,
                                       monkeypatch: pytest.MonkeyPatch) -> None:
    from aamcore.expression import learning

    X, y, people = five_posers.features, five_posers.labels, five_posers.posers
    sets = np.full(len(y), "jaffe")
    recipe = Recipe(folds=3, learner="network", hidden=16, epochs=20, seeds=2,
                    class_biases=True, min_reference_faces=1)
    learned = {}
    for threads in (1, 3):
        monkeypatch.setattr(learning, "THREADS", threads)
        learned[threads] = learn(X, y, people, sets, {"hog": X.shape[1]}, recipe)
    one, many = learned[1], learned[3]
    assert one.absolute.model.hidden_coef.shape[1] == 32  # two seeds of 16 units
    np.testing.assert_array_equal(one.absolute.scores(X), many.absolute.scores(X))
    assert one.absolute_temperature == many.absolute_temperature
