"""aamcore.fitting.training.binary: the whole cascade and its training samples."""

from __future__ import annotations

import numpy as np

from aamcore.fitting.shape_space import ShapeSpace
from aamcore.fitting.training.binary import (
    THRESHOLD,
    BinaryTrainConfig,
    coarse_samples,
    occluded_copies,
    on_occluded,
    restart_samples,
    tracking_samples,
)


def test_the_cascade_has_what_the_recipe_asks(synthetic_binary, synthetic_binary_config) -> None:
    config = synthetic_binary_config
    assert len(synthetic_binary.coarse) == len(config.coarse)
    assert len(synthetic_binary.tracking) == len(config.tracking)
    assert synthetic_binary.tracking[0].n_ferns == 3 * synthetic_binary.space.n_points
    assert [s.radius for s in synthetic_binary.restart] == [
        c.radius * synthetic_binary.space.eye_distance for c in config.restart]
    assert synthetic_binary.quality.bias.shape == (1,)
    assert synthetic_binary.threshold == config.threshold
    report = synthetic_binary.report
    assert report["faces"] == 40 and report["no_face_frames"] == 6
    assert report["config"]["tracking"][0]["n_ferns"] == 3


def test_default_recipe_is_the_research_one() -> None:
    config = BinaryTrainConfig()
    assert len(config.coarse) == 6 and [f.radius for f in config.tracking] == [0.2, 0.12, 0.08]
    assert all(f.n_ferns == 4 and f.depth == 5 for f in config.tracking)
    assert [f.radius for f in config.restart] == [0.4, 0.3, 0.2] and config.restart_starts == 4
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


def test_restart_samples_start_from_the_mean_placed_near_the_truth(synthetic_training_faces
                                                                   ) -> None:
    faces = synthetic_training_faces
    space = ShapeSpace.train(np.stack([f.points for f in faces]), 0.98, (0, 1))
    config = BinaryTrainConfig(restart_starts=3)
    samples = restart_samples(space, faces, config, np.random.default_rng(2))
    assert len(samples.owners) == 3 * len(faces) and samples.folds is not None
    ab = space.similarity(samples.shapes)
    rot = np.stack([np.stack([ab[:, 0], ab[:, 1]], -1), np.stack([-ab[:, 1], ab[:, 0]], -1)], 1)
    centred = samples.shapes - samples.shapes.mean(axis=1, keepdims=True)
    s2 = (ab ** 2).sum(axis=1)[:, None, None]
    model = np.einsum("snk,sjk->snj", centred, rot) / s2  # back in the model frame
    assert np.allclose(model, space.mean, atol=1e-6)  # every start is the mean shape
    truth_centres = samples.truths.mean(axis=1)
    shift = np.linalg.norm(samples.shapes.mean(axis=1) - truth_centres, axis=1)
    assert np.all(shift < 0.5 * np.ptp(samples.truths[..., 0], axis=1))


def test_occluded_copies_cover_each_face_and_a_share_of_samples_reads_them(
        synthetic_training_faces) -> None:
    faces = synthetic_training_faces
    copies = occluded_copies(faces, np.random.default_rng(0))
    assert len(copies) == len(faces)
    for face, copy in zip(faces, copies, strict=True):
        assert copy.shape == face.grey.shape and copy.dtype == np.uint8
        changed = np.argwhere(copy != face.grey)
        assert len(changed), "every copy has an occluder drawn on it"
        lo, hi = face.points.min(axis=0), face.points.max(axis=0)
        centre = changed[:, ::-1].mean(axis=0)  # (x, y): the occluder lies on the face
        assert np.all(centre > lo - 0.5 * (hi - lo)) and np.all(centre < hi + 0.5 * (hi - lo))
    space = ShapeSpace.train(np.stack([f.points for f in faces]), 0.98, (0, 1))
    samples = tracking_samples(space, faces, BinaryTrainConfig(track_starts=25),
                               np.random.default_rng(1))
    moved = on_occluded(samples.owners, len(faces), 0.25, np.random.default_rng(2))
    on_copy = moved >= len(faces)
    assert 0.15 < on_copy.mean() < 0.35
    assert np.array_equal(np.where(on_copy, moved - len(faces), moved),
                          samples.owners)  # each sample reads its own face's copy
    assert on_occluded(samples.owners, len(faces), 0.0, np.random.default_rng(2)) is (
        samples.owners)
