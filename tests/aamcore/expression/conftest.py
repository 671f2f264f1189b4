"""Real JAFFE data shared by the expression tests: the faces as the stack fits them, and
feature matrices of them."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.expression.analysis import observe
from aamcore.expression.faces import LabelledFaces
from aamcore.expression.spec import FeatureConfig
from tests.aamcore.expression.feature_sets import FeatureSet

FIVE_POSERS = ["KA", "KL", "KM", "KR", "MK"]


@pytest.fixture(scope="session")
def jaffe_features(jaffe: LabelledFaces) -> FeatureSet:
    """Absolute HOG patch features (213, 1836) of every JAFFE face, with labels and posers."""
    observed = observe(jaffe.observations, FeatureConfig(blocks=("hog",)))
    assert observed.ok.all(), [p for p in observed.problems if p]
    return FeatureSet(observed.vectors(("hog",)), jaffe.labels, jaffe.posers)


@pytest.fixture(scope="session")
def five_posers(jaffe_features: FeatureSet) -> FeatureSet:
    """The samples of five posers (about 105)."""
    return jaffe_features.subset(np.isin(jaffe_features.posers, FIVE_POSERS))
