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


def test_the_thesis_classifiers_label_a_poser_they_never_saw(five_posers: FeatureSet) -> None:
    specs = default_classifiers(n_trials=2, C_grid=np.array([8.0]), gamma_grid=np.array([0.5]))
    assert [s.name for s in specs] == ["LDA+Mahalanobis", "SVM OvA", "SVM OvO", "SVM DAG"]
    train = five_posers.posers != "KA"
    X, truth = reduced(five_posers, train), five_posers.labels[~train]
    for spec in specs:
        model = spec.fit(X[train], five_posers.labels[train], five_posers.posers[train])
        right = int(np.sum(model.predict(X[~train]) == truth))
        # seven classes: chance is one in seven; a classifier that learned nothing of the
        # expressions (shuffled labels, one class said of all) is not this far above it
        assert binomtest(right, len(truth), 1 / 7, alternative="greater").pvalue < 1e-3, (
            spec.name, right, len(truth))


def test_the_chosen_fisher_directions_do_as_well_as_all_of_them(five_posers: FeatureSet
                                                                ) -> None:
    """Eq 9.8 keeps the directions that carry the classes apart: on a poser left out, the
    classifier with them is not worse than the one with all six that LDA allows. Of the
    faces one of the two labels right and the other wrong, the chosen one loses no more than
    a coin would make it lose (an exact sign test: a poser has some twenty faces, so a few
    faces either way is the luck of the fitted landmarks, not a worse classifier)."""
    train = five_posers.posers != "KA"
    X, truth = reduced(five_posers, train), five_posers.labels[~train]
    chosen = lda_mahalanobis_spec(n_trials=2).fit(X[train], five_posers.labels[train],
                                                  five_posers.posers[train])
    every = FisherMahalanobis().fit(X[train], five_posers.labels[train])
    assert every.transform(X[:1]).shape[1] == 6  # seven classes: six Fisher directions
    assert chosen.transform(X[:1]).shape[1] <= 6
    ok_chosen, ok_every = chosen.predict(X[~train]) == truth, every.predict(X[~train]) == truth
    lost, won = int(np.sum(ok_every & ~ok_chosen)), int(np.sum(ok_chosen & ~ok_every))
    worse = binomtest(lost, lost + won, 0.5, alternative="greater").pvalue if lost else 1.0
    assert worse > 0.01, (int(ok_chosen.sum()), int(ok_every.sum()), lost, won)
    assert binomtest(int(ok_chosen.sum()), len(truth), 1 / 7,
                     alternative="greater").pvalue < 1e-3
