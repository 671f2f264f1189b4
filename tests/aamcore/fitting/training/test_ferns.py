"""aamcore.fitting.training.ferns: the sparse ridge, the ferns' leaves, a stage that helps."""

from __future__ import annotations

import numpy as np

from aamcore.fitting.shape_space import ShapeSpace
from aamcore.fitting.training.faces import PackedImages
from aamcore.fitting.training.ferns import (
    FernConfig,
    Samples,
    fern_leaves,
    landmark_ferns,
    leaf_ridge,
    random_pairs,
    stage_solves,
    train_fern_stage,
)
from aamcore.fitting.training.perturb import perturbed_starts


def test_pairs_lie_in_the_disc() -> None:
    pairs = random_pairs(np.random.default_rng(0), 500, 3.0)
    assert pairs.shape == (500, 4)
    assert np.all(np.hypot(pairs[:, 0::2], pairs[:, 1::2]) <= 3.0 + 1e-12)


def one_hot(leaves: np.ndarray, n_features: int) -> np.ndarray:
    """The dense one-hot leaf features (S, D) of ``leaves`` (S, T)."""
    x = np.zeros((len(leaves), n_features))
    x[np.repeat(np.arange(len(leaves)), leaves.shape[1]), leaves.ravel()] = 1.0
    return x


def dense_ridge(leaves: np.ndarray, n_features: int, targets: np.ndarray, strength: float
                ) -> np.ndarray:
    """The documented ridge solved densely by numpy: each sample's prediction (S, Q) of
    ``targets``' deviation from their mean, with a penalty of ``strength`` times the mean
    count of samples per used leaf."""
    x = one_hot(leaves, n_features)
    counts = x.sum(axis=0)
    alpha = strength * counts[counts > 0].mean()
    centred = targets - targets.mean(axis=0)
    return np.linalg.solve(x.T @ x + alpha * np.eye(n_features), x.T @ centred)


def test_leaf_ridge_matches_the_dense_solve() -> None:
    rng = np.random.default_rng(1)
    n, t, leaves_per = 300, 4, 8
    leaves = rng.integers(0, leaves_per, (n, t)) + np.arange(t) * leaves_per
    targets = rng.normal(size=(n, 3))
    weights, bias = leaf_ridge(leaves, t * leaves_per, targets, 0.5, 200)
    x = one_hot(leaves, t * leaves_per)
    dense = dense_ridge(leaves, t * leaves_per, targets, 0.5)
    assert np.allclose(bias, targets.mean(axis=0))
    # float32 products: agreement to float32's precision
    assert weights.dtype == np.float32
    assert np.allclose(x @ weights, x @ dense, atol=1e-4)


def test_the_threaded_solves_are_the_sequential_ones() -> None:
    rng = np.random.default_rng(3)
    n, t, leaves_per = 400, 5, 8
    leaves = rng.integers(0, leaves_per, (n, t)) + np.arange(t) * leaves_per
    targets = rng.normal(size=(n, 2))
    folds = rng.integers(0, 2, n)
    config = FernConfig(1.0, cg_iterations=30)
    one = stage_solves(leaves, t * leaves_per, targets, folds, config, 1)
    two = stage_solves(leaves, t * leaves_per, targets, folds, config, 2)
    for a, b in zip(one, two, strict=True):
        assert np.array_equal(a, b)
    # each fold's steps come from the regression learned without it (numpy's dense solve of
    # the same ridge; 30 conjugate-gradient steps in float32 agree to 1e-3)
    n_features = t * leaves_per
    for fold in (0, 1):
        out = folds == fold
        dense = dense_ridge(leaves[~out], n_features, targets[~out], config.ridge)
        expected = one_hot(leaves[out], n_features) @ dense + targets[~out].mean(axis=0)
        assert np.allclose(one[2][out], expected, atol=1e-3)
    # without folds, every step from the regression learned from all
    steps = stage_solves(leaves, t * leaves_per, targets, None, config, 2)[2]
    expected = (one_hot(leaves, n_features) @ dense_ridge(leaves, n_features, targets,
                                                         config.ridge) + targets.mean(axis=0))
    assert np.allclose(steps, expected, atol=1e-3)


def test_fern_leaves_follow_the_tests() -> None:
    rng = np.random.default_rng(2)
    values = rng.normal(0, 20, (200, 30)).astype(np.float32)
    target = values[:, :2] @ np.array([[1.0, 0.0], [0.0, 1.0]])
    config = FernConfig(1.0, n_ferns=2, depth=3, n_pairs=30, candidates=0.5)
    pairs = random_pairs(rng, 30, 1.0)
    offsets, thresholds, leaves = landmark_ferns(values, pairs, target, config, rng)
    assert offsets.shape == (6, 4) and thresholds.shape == (6,) and leaves.shape == (200, 2)
    chosen = [int(np.flatnonzero(np.all(pairs.astype(np.float32) == o, axis=1))[0])
              for o in offsets]
    bits = values[:, chosen] > thresholds
    expected = np.stack([bits[:, 3 * f:3 * f + 3] @ [1, 2, 4] for f in range(2)], axis=1)
    assert np.array_equal(leaves, expected)


def test_a_stage_brings_tracking_starts_closer(synthetic_training_faces) -> None:
    faces = synthetic_training_faces
    truths = np.stack([f.points for f in faces])
    space = ShapeSpace.train(truths, 0.98, (0, 1))
    rng = np.random.default_rng(3)
    owners = np.repeat(np.arange(len(faces)), 6)
    starts = perturbed_starts(space, truths[owners], np.zeros(4), np.array([0.03, 0.03, 3, 3]),
                              rng, shape_sd=0.3)
    folds = owners % 2
    samples = Samples(owners, truths[owners], starts, folds)
    packed = PackedImages.pack([f.grey for f in faces])
    stage, steps = train_fern_stage(packed, samples, space, FernConfig(0.3, n_ferns=3), rng)
    moved = space.apply_steps(starts, steps, project=False)
    before = np.linalg.norm(starts - truths[owners], axis=-1).mean()
    after = np.linalg.norm(moved - truths[owners], axis=-1).mean()
    assert after < 0.8 * before  # cross-fitted: as on faces the stage has not seen
    leaves = fern_leaves(packed, owners, starts, space, stage)
    in_sample = stage.weights.astype(np.float64)[leaves].sum(axis=1) + stage.bias
    assert in_sample.shape == steps.shape and stage.n_points == space.n_points


def test_tests_chosen_on_a_subset_are_the_leaves_of_every_sample(
        synthetic_training_faces) -> None:
    faces = synthetic_training_faces
    truths = np.stack([f.points for f in faces])
    space = ShapeSpace.train(truths, 0.98, (0, 1))
    rng = np.random.default_rng(4)
    owners = np.repeat(np.arange(len(faces)), 6)
    starts = perturbed_starts(space, truths[owners], np.zeros(4), np.array([0.03, 0.03, 3, 3]),
                              rng, shape_sd=0.3)
    samples = Samples(owners, truths[owners], starts, owners % 2)
    packed = PackedImages.pack([f.grey for f in faces])
    config = FernConfig(0.3, n_ferns=3, grow_samples=len(owners) // 3, warm_iterations=15)
    stage, steps = train_fern_stage(packed, samples, space, config, rng)
    # the stage as the fitter runs it sends every sample to the leaves it was learned with
    leaves = fern_leaves(packed, owners, starts, space, stage)
    moved = space.apply_steps(starts, steps, project=False)
    before = np.linalg.norm(starts - truths[owners], axis=-1).mean()
    assert np.linalg.norm(moved - truths[owners], axis=-1).mean() < 0.8 * before
    in_sample = stage.weights.astype(np.float64)[leaves].sum(axis=1) + stage.bias
    fitted = space.apply_steps(starts, in_sample, project=False)
    assert np.linalg.norm(fitted - truths[owners], axis=-1).mean() < 0.8 * before


def test_the_solve_on_every_sample_starts_from_the_folds_and_reaches_the_cold_one() -> None:
    rng = np.random.default_rng(5)
    n, t, leaves_per = 600, 6, 8
    leaves = rng.integers(0, leaves_per, (n, t)) + np.arange(t) * leaves_per
    targets = leaves @ rng.normal(size=(t, 2)) * 0.1 + rng.normal(size=(n, 2))
    folds = rng.integers(0, 2, n)
    config = FernConfig(1.0, cg_iterations=60, warm_iterations=10)
    warm = stage_solves(leaves, t * leaves_per, targets, folds, config, 1)
    cold = leaf_ridge(leaves, t * leaves_per, targets, config.ridge, 200)
    assert np.allclose(warm[0], cold[0], atol=1e-3) and np.allclose(warm[1], cold[1])
