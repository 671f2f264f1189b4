"""aamcore.expression.thesis_classifiers: the thesis's classifiers, each fitted inside the
training posers, label a poser they never saw far above chance."""

from __future__ import annotations

import numpy as np
from scipy.stats import binomtest
from sklearn.decomposition import PCA

from aamcore.expression.lda import FisherMahalanobis
from aamcore.expression.thesis_classifiers import default_classifiers, lda_mahalanobis_spec
from tests.aamcore.expression.feature_sets import FeatureSet


def reduced(faces: FeatureSet, train: np.ndarray) -> np.ndarray:
    """The HOG features (n, 30) of every face in the 30 principal directions of the training
    faces' (a few classes' worth of samples per direction, as the thesis's c is)."""
    return PCA(30, random_state=0).fit(faces.features[train]).transform(faces.features)


def left_out_in_turn(faces: FeatureSet, fit) -> tuple[np.ndarray, np.ndarray]:
    """Every face labelled by ``fit(X_train, labels, posers)``'s model fitted on the other
    posers (each poser left out in turn), and the true labels, in the faces' order: one
    poser's twenty faces are as much the luck of its fitted landmarks as the classifier."""
    said = np.empty(len(faces.labels), dtype=faces.labels.dtype)
    for poser in np.unique(faces.posers):
        train = faces.posers != poser
        X = reduced(faces, train)
        model = fit(X[train], faces.labels[train], faces.posers[train])
        said[~train] = model.predict(X[~train])
    return said, faces.labels


def test_the_thesis_classifiers_label_a_poser_they_never_saw(five_posers: FeatureSet) -> None:
    specs = default_classifiers(n_trials=2, C_grid=np.array([8.0]), gamma_grid=np.array([0.5]))
    assert [s.name for s in specs] == ["LDA+Mahalanobis", "SVM OvA", "SVM OvO", "SVM DAG"]
    for spec in specs:
        said, truth = left_out_in_turn(five_posers, spec.fit)
        right = int(np.sum(said == truth))
        # seven classes: chance is one in seven; a classifier that learned nothing of the
        # expressions (shuffled labels, one class said of all) is not this far above it
        assert binomtest(right, len(truth), 1 / 7, alternative="greater").pvalue < 1e-6, (
            spec.name, right, len(truth))


def test_the_chosen_fisher_directions_do_as_well_as_all_of_them(five_posers: FeatureSet
                                                                ) -> None:
    """Eq 9.8 keeps the directions that carry the classes apart: on posers left out, the
    classifier with them is not worse than the one with all six that LDA allows. Of the
    faces one of the two labels right and the other wrong, the chosen one loses no more than
    a coin would make it lose (an exact sign test over the five posers' faces)."""
    chosen = lda_mahalanobis_spec(n_trials=2)
    said, truth = left_out_in_turn(five_posers, chosen.fit)
    every, _ = left_out_in_turn(five_posers, lambda X, y, _: FisherMahalanobis().fit(X, y))
    train = five_posers.posers != "KA"
    X = reduced(five_posers, train)
    fitted = chosen.fit(X[train], five_posers.labels[train], five_posers.posers[train])
    assert FisherMahalanobis().fit(X[train], five_posers.labels[train]).transform(
        X[:1]).shape[1] == 6  # seven classes: six Fisher directions
    assert fitted.transform(X[:1]).shape[1] <= 6
    ok_chosen, ok_every = said == truth, every == truth
    lost, won = int(np.sum(ok_every & ~ok_chosen)), int(np.sum(ok_chosen & ~ok_every))
    worse = binomtest(lost, lost + won, 0.5, alternative="greater").pvalue if lost else 1.0
    assert worse > 0.01, (int(ok_chosen.sum()), int(ok_every.sum()), lost, won)
    assert binomtest(int(ok_chosen.sum()), len(truth), 1 / 7,
                     alternative="greater").pvalue < 1e-6
