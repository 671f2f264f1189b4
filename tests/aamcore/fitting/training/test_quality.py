"""aamcore.fitting.training.quality: the score's targets and samples, calibration, rates."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.fitting.algorithm.local_binary import LocalBinary
from aamcore.fitting.shape_space import ShapeSpace
from aamcore.fitting.training.quality import (
    NO_FACE_NME,
    QualityConfig,
    calibrate,
    failure_rates,
    nme_of,
    quality_samples,
    quality_target,
)


def test_nme_and_target() -> None:
    truth = np.zeros((1, 68, 2))
    truth[0, 36], truth[0, 45] = (0, 0), (10, 0)
    assert nme_of(truth + [1.0, 0.0], truth)[0] == pytest.approx(0.1)
    assert np.allclose(quality_target(np.array([0.0, 0.1, 5.0])),
                       np.log([0.005, 0.1, NO_FACE_NME]))


def test_samples_range_from_good_to_far(synthetic_faces) -> None:
    truths = np.stack([s.points for s in synthetic_faces.train])
    space = ShapeSpace.train(truths, 0.98, (0, 1))
    owners, shapes, nme = quality_samples(space, truths, QualityConfig(per_face=5),
                                          np.random.default_rng(0))
    assert len(owners) == len(shapes) == len(nme) == 5 * len(truths)
    assert nme.min() < 0.05 and nme.max() > 0.3


def test_calibration_and_rates() -> None:
    scores = np.arange(100, dtype=float)
    assert calibrate(scores, 0.99) == pytest.approx(98.01)
    rates = failure_rates([-4.0, -3.0, -1.0, -2.0, 0.0], [0.02, 0.05, 0.03, 0.5, 1.0], -2.5)
    assert rates == {"kept_good": pytest.approx(2 / 3), "rejected_bad": 1.0, "n_good": 3,
                     "n_bad": 2}


def test_the_trained_score_ranks_errors(synthetic_binary, synthetic_faces) -> None:
    method = LocalBinary(synthetic_binary)
    truths = np.stack([s.points for s in synthetic_faces.test])
    space = synthetic_binary.space
    _, shapes, nme = quality_samples(space, truths, QualityConfig(per_face=8),
                                     np.random.default_rng(5))
    owners = np.repeat(np.arange(len(truths)), 8)
    scores = [method.score(synthetic_faces.test[k].load_image(), s)
              for k, s in zip(owners, shapes, strict=True)]
    assert np.corrcoef(scores, np.log(nme))[0, 1] > 0.6
