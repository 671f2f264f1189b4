"""aamcore.expression.thesis_classifiers: the thesis's classifiers fit inside the training
data."""

from __future__ import annotations

import numpy as np

from aamcore.expression.thesis_classifiers import default_classifiers, lda_mahalanobis_spec
from tests.aamcore.expression.feature_sets import FeatureSet


def test_the_thesis_classifiers_fit_inside_the_training_data(five_posers: FeatureSet) -> None:
    specs = default_classifiers(n_trials=2, C_grid=np.array([8.0]), gamma_grid=np.array([0.5]))
    assert [s.name for s in specs] == ["LDA+Mahalanobis", "SVM OvA", "SVM OvO", "SVM DAG"]
    X = five_posers.features[:, :50]
    train = five_posers.posers != "KA"
    for spec in specs:
        model = spec.fit(X[train], five_posers.labels[train], five_posers.posers[train])
        assert set(model.predict(X[~train])) <= set(five_posers.labels)
    lda = lda_mahalanobis_spec(n_trials=2).fit(X, five_posers.labels, five_posers.posers)
    assert 1 <= lda.n_components <= 6
