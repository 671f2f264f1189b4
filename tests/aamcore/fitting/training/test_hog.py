"""aamcore.fitting.training.hog: descriptors in threads, a coarse stage that helps."""

from __future__ import annotations

import numpy as np

from aamcore.fitting.algorithm.local_hog import LandmarkHog
from aamcore.fitting.shape_space import ShapeSpace
from aamcore.fitting.training.ferns import Samples
from aamcore.fitting.training.hog import HogConfig, hog_features, train_hog_cascade


def test_coarse_stages_bring_box_starts_closer(synthetic_training_faces) -> None:
    faces = synthetic_training_faces
    truths = np.stack([f.points for f in faces])
    space = ShapeSpace.train(truths, 0.98, (0, 1))
    greys = [f.grey for f in faces]
    owners = np.arange(len(faces))
    starts = space.project(np.stack([f.start for f in faces]))
    extractor = LandmarkHog(space.mean, 24.0, 16, 2, space.eye_distance)
    one = hog_features(greys, owners, starts, extractor, 1)
    two = hog_features(greys, owners, starts, extractor, 2)
    assert np.array_equal(one, two) and one.shape == (len(faces), 36 * space.n_points)
    samples = Samples(owners, truths, starts.copy())
    stages = train_hog_cascade(greys, samples, space, [HogConfig(24.0, 16)] * 2, 1.0)
    assert len(stages) == 2
    before = np.linalg.norm(starts - truths, axis=-1).mean()
    after = np.linalg.norm(samples.shapes - truths, axis=-1).mean()
    assert after < 0.7 * before


def test_the_gram_matrix_in_float32_blocks_is_the_float64_one() -> None:
    from aamcore.fitting.training.hog import centred_gram

    x = np.random.default_rng(0).uniform(0.0, 0.4, (3001, 50)).astype(np.float32)
    xc = x - x.mean(axis=0)
    exact = xc.astype(np.float64).T @ xc.astype(np.float64)
    for jobs in (1, 2):
        gram = centred_gram(xc, jobs)
        assert gram.dtype == np.float64
        assert np.abs(gram - exact).max() < 1e-5 * np.abs(exact).max()
