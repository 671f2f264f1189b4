"""aamcore.fitting.training.binary: the whole cascade and its training samples."""

from __future__ import annotations

import numpy as np

from aamcore.fitting.shape_space import ShapeSpace
from aamcore.fitting.training.binary import (
    THRESHOLD,
    BinaryTrainConfig,
    coarse_samples,
    tracking_samples,
)


def test_the_cascade_has_what_the_recipe_asks(synthetic_binary, synthetic_binary_config) -> None:
    config = synthetic_binary_config
    assert len(synthetic_binary.coarse) == len(config.coarse)
    assert len(synthetic_binary.tracking) == len(config.tracking)
    assert synthetic_binary.tracking[0].n_ferns == 3 * synthetic_binary.space.n_points
    assert synthetic_binary.quality.bias.shape == (1,)
    assert synthetic_binary.threshold == config.threshold
    report = synthetic_binary.report
    assert report["faces"] == 40 and report["no_face_frames"] == 6
    assert report["config"]["tracking"][0]["n_ferns"] == 3


def test_default_recipe_is_the_research_one() -> None:
    config = BinaryTrainConfig()
    assert len(config.coarse) == 6 and [f.radius for f in config.tracking] == [0.2, 0.12, 0.08]
    assert all(f.n_ferns == 4 and f.depth == 5 for f in config.tracking)
    assert config.shape_variance == 0.995 and config.threshold == THRESHOLD == -2.47


def test_samples_start_from_the_real_start_and_fold_by_photo(synthetic_training_faces) -> None:
    faces = synthetic_training_faces
    space = ShapeSpace.train(np.stack([f.points for f in faces]), 0.98, (0, 1))
    config = BinaryTrainConfig(starts=3, track_starts=2)
    samples, report = coarse_samples(space, faces, config, np.random.default_rng(0))
    assert len(samples.owners) == 3 * len(faces) and report["detected"] == 0.0
    assert np.allclose(samples.shapes[0], space.project(faces[0].start[None])[0])
    tracking = tracking_samples(space, faces, config, np.random.default_rng(1))
    assert tracking.folds is not None and set(tracking.folds.tolist()) == {0, 1}
    assert np.array_equal(tracking.folds[::2], tracking.folds[1::2])  # a photo in one fold
