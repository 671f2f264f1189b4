"""Learning the fern stages of the local-binary cascade (Ren et al. 2014, Cao et al. 2012).

For every landmark a few ferns are grown on pixel differences sampled around it
in the frame of the current shape: each test is the candidate pair best
correlated with a random projection of the landmark's residual, its threshold a
random quantile of the pair's differences. The leaves the training samples reach
are then the one-hot features of one ridge regression, for all landmarks
together, of the step in the shape basis (preconditioned conjugate gradients on
the sparse leaves).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from aamcore.fitting.algorithm.ferns import FernStage
from aamcore.fitting.shape_space import ShapeSpace
from aamcore.fitting.training.faces import PackedImages


@dataclass(frozen=True)
class FernConfig:
    """What one fern stage learns.

    Attributes
    ----------
    radius : float
        Pixels are sampled within this radius of their landmark, as a fraction
        of the mean shape's eye-corner distance.
    n_ferns : int
        Ferns per landmark.
    depth : int
        Tests per fern.
    n_pairs : int
        Candidate pixel pairs per landmark the tests are chosen from.
    candidates : float
        Share of the pairs tried for each test.
    ridge : float
        Ridge penalty as a fraction of the mean number of samples per used leaf.
    cg_iterations : int
        Conjugate-gradient iterations of a ridge solve from the preconditioner's guess.
    warm_iterations : int
        Iterations of the solve on all samples, started from the mean of the cross-fitting
        folds' solutions.
    grow_samples : int, optional
        The tests are chosen on a random subset of at most this many samples (None: all).
    """

    radius: float
    n_ferns: int = 4
    depth: int = 5
    n_pairs: int = 200
    candidates: float = 0.1
    ridge: float = 2.0
    cg_iterations: int = 40
    warm_iterations: int = 40
    grow_samples: int | None = None


@dataclass
class Samples:
    """Training samples: which image, true shape and current shape.

    Attributes
    ----------
    owners : (S,) int64 array
    truths : (S, N, 2) float64 array
    shapes : (S, N, 2) float64 array
    folds : (S,) int64 array, optional
        Cross-fitting fold of each sample (a photo and its mirror image in one
        fold); None to advance the samples with the in-sample regression.
    """

    owners: np.ndarray
    truths: np.ndarray
    shapes: np.ndarray
    folds: np.ndarray | None = None


def random_pairs(rng: np.random.Generator, n_pairs: int, radius: float) -> np.ndarray:
    """``n_pairs`` pixel pairs (P, 4), each point uniform in the disc of ``radius``."""
    r = radius * np.sqrt(rng.uniform(size=(n_pairs, 2)))
    angle = rng.uniform(0, 2 * np.pi, size=(n_pairs, 2))
    return np.stack([r * np.cos(angle), r * np.sin(angle)], axis=-1).reshape(n_pairs, 4)


def landmark_ferns(
    values: np.ndarray, pairs: np.ndarray, target: np.ndarray, config: FernConfig,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One landmark's ferns from the differences ``values`` (S, P) of ``pairs`` (P, 4).

    Parameters
    ----------
    target : (S, D) array
        What the ferns should tell apart (the landmark's residual, or a score).

    Returns
    -------
    offsets : (F * depth, 4) float32 array
    thresholds : (F * depth,) float32 array
    leaves : (S, F) int64 array
        The leaf each sample reaches in each fern.
    """
    centred = values - values.mean(axis=0)
    norms = np.sqrt(np.einsum("ij,ij->j", centred, centred)) + 1e-9
    n_candidates = max(1, int(round(config.candidates * config.n_pairs)))
    chosen, cuts = [], []
    leaves = np.zeros((len(values), config.n_ferns), dtype=np.int64)
    for f in range(config.n_ferns):
        for k in range(config.depth):
            y = target @ rng.standard_normal(target.shape[1])
            y = y - y.mean()
            candidates = rng.choice(config.n_pairs, size=n_candidates, replace=False)
            corr = np.abs(y @ centred[:, candidates]) / norms[candidates]
            j = int(candidates[int(np.argmax(corr))])
            cut = np.float32(np.quantile(values[:, j], rng.uniform(0.25, 0.75)))
            leaves[:, f] += (values[:, j] > cut).astype(np.int64) << k
            chosen.append(j)
            cuts.append(cut)
    return pairs[chosen].astype(np.float32), np.array(cuts, dtype=np.float32), leaves


def leaf_matrix(leaves: np.ndarray, n_features: int) -> sp.csr_matrix:
    """The one-hot features (S, D) float32 of samples reaching ``leaves`` (S, T): one 1 per
    fern and sample."""
    n, t = leaves.shape
    return sp.csr_matrix((np.ones(n * t, np.float32), leaves.ravel(), np.arange(0, n * t + 1, t)),
                         shape=(n, n_features))


def leaf_ridge(leaves: np.ndarray, n_features: int, targets: np.ndarray, strength: float,
               iterations: int, start: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
    """Ridge regression on one-hot leaf features, by preconditioned conjugate gradients.

    The products run in float32 (the sparse products are bound by memory: half the bytes,
    about half the time) and the CG's inner products in float64. ``X^T v`` is the
    transposed view's product (compressed by column: it scatters each sample's row, which
    reads memory in order and takes half the time of a product by a transposed copy).

    Parameters
    ----------
    leaves : (S, T) int array
        Global index of the leaf each sample reaches in each fern.
    n_features : int
        Number of leaves in all (``D``).
    targets : (S, Q) array
    strength : float
        Penalty as a fraction of the mean count of samples per used leaf.
    iterations : int
    start : (D, Q) array, optional
        Weights to start from (the diagonal preconditioner's first guess by default).

    Returns
    -------
    weights : (D, Q) float32 array
    bias : (Q,) float64 array
        The targets' mean (the leaves of a fern sum to one, so the weights need
        no intercept of their own).
    """
    t = leaves.shape[1]
    x = leaf_matrix(leaves, n_features)
    xt = x.T
    counts = np.bincount(leaves.ravel(), minlength=n_features).astype(np.float64)
    alpha = np.float32(strength * float(counts[counts > 0].mean()))
    bias = targets.mean(axis=0)
    rhs = xt @ (targets - bias).astype(np.float32)
    # the diagonal of X^T X is the counts; t rescales
    inverse = (1.0 / (counts * t + alpha)).astype(np.float32)[:, None]

    def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.einsum("dq,dq->q", a, b, dtype=np.float64)

    weights = rhs * inverse if start is None else np.array(start, np.float32)
    residual = rhs - (xt @ (x @ weights) + alpha * weights)
    z = residual * inverse
    direction = z.copy()
    rz = dot(residual, z)
    for _ in range(iterations):
        g = xt @ (x @ direction) + alpha * direction
        step = (rz / np.maximum(dot(direction, g), 1e-300)).astype(np.float32)
        weights += step * direction
        residual -= step * g
        z = residual * inverse
        rz_new = dot(residual, z)
        direction = z + (rz_new / np.maximum(rz, 1e-300)).astype(np.float32) * direction
        rz = rz_new
    return weights, bias


def grow_ferns(
    packed: PackedImages, samples: Samples, space: ShapeSpace, targets: np.ndarray,
    config: FernConfig, rng: np.random.Generator, n_jobs: int = 1,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every landmark's ferns, landmark after landmark.

    ``targets`` (S, N, D) is what the ferns of each landmark tell apart. The tests are
    chosen on at most ``config.grow_samples`` of the samples (a random subset); every
    sample then goes through them.
    Returns the stage's offsets (T depth, 4), thresholds (T depth,) and the
    samples' global leaf indices (S, T), ``T = N * n_ferns``.
    """
    radius = config.radius * space.eye_distance
    ab = space.similarity(samples.shapes)
    seeds = rng.integers(2**62, size=space.n_points)
    every = len(samples.owners)
    subset = config.grow_samples is not None and config.grow_samples < every
    grow = np.sort(rng.choice(every, config.grow_samples, replace=False)) if subset else slice(
        None)
    powers = 1 << np.arange(config.depth)

    def work(landmark: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        own = np.random.default_rng(int(seeds[landmark]))
        pairs = random_pairs(own, config.n_pairs, radius)
        anchors = samples.shapes[:, landmark]
        values = packed.differences(samples.owners[grow], anchors[grow], ab[grow], pairs)
        offsets, cuts, leaves = landmark_ferns(values, pairs, targets[grow, landmark], config,
                                               own)
        if subset:
            chosen = packed.differences(samples.owners, anchors, ab, offsets)
            bits = (chosen > cuts).reshape(every, config.n_ferns, config.depth)
            leaves = bits.astype(np.int64) @ powers
        return offsets, cuts, leaves

    if n_jobs > 1:
        with ThreadPoolExecutor(n_jobs) as pool:
            results = list(pool.map(work, range(space.n_points)))
    else:
        results = [work(k) for k in range(space.n_points)]
    n_leaves = 2**config.depth
    leaves = np.concatenate([r[2] for r in results], axis=1)
    leaves += np.arange(leaves.shape[1]) * n_leaves
    return (np.concatenate([r[0] for r in results]), np.concatenate([r[1] for r in results]),
            leaves)


def stage_solves(leaves: np.ndarray, n_features: int, targets: np.ndarray,
                 folds: np.ndarray | None, config: FernConfig, n_jobs: int
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The stage's weights (D, Q) and bias (Q,) from all samples, and each sample's step
    (S, Q): where ``folds`` is set, by a regression learned without the sample's fold, so
    that the next stage learns from residuals as large as unseen faces leave.

    The fold regressions are solved first (in ``n_jobs`` threads: the sparse products
    release the GIL); the regression on all samples then starts from their mean, already
    close, and takes ``config.warm_iterations`` steps instead of ``config.cg_iterations``.
    """
    def solve(used: np.ndarray, iterations: int, start: np.ndarray | None = None
              ) -> tuple[np.ndarray, np.ndarray]:
        return leaf_ridge(leaves[used], n_features, targets[used], config.ridge, iterations,
                          start)

    every = np.ones(len(leaves), bool)
    if folds is None:
        weights, bias = solve(every, config.cg_iterations)
        steps = leaf_matrix(leaves, n_features) @ weights + bias
        return weights, bias, steps.astype(targets.dtype)
    subsets = [folds != fold for fold in np.unique(folds)]
    if n_jobs > 1:
        with ThreadPoolExecutor(n_jobs) as pool:
            solved = list(pool.map(lambda used: solve(used, config.cg_iterations), subsets))
    else:
        solved = [solve(used, config.cg_iterations) for used in subsets]
    steps = np.empty_like(targets)
    for used, (w, b) in zip(subsets, solved, strict=True):
        steps[~used] = leaf_matrix(leaves[~used], n_features) @ w + b
    start = np.mean([w for w, _ in solved], axis=0)
    weights, bias = solve(every, config.warm_iterations, start)
    return weights, bias, steps


def train_fern_stage(
    packed: PackedImages, samples: Samples, space: ShapeSpace, config: FernConfig,
    rng: np.random.Generator, n_jobs: int = 1,
) -> tuple[FernStage, np.ndarray]:
    """Learn one stage from ``samples`` (not changed).

    Returns
    -------
    stage : FernStage
    steps : (S, Q) array
        The stage's step for each sample (cross-fitted where ``samples.folds`` is set).
    """
    residual = space.to_model_frame(samples.shapes, samples.truths - samples.shapes)
    offsets, thresholds, leaves = grow_ferns(packed, samples, space, residual, config, rng,
                                             n_jobs)
    n_features = leaves.shape[1] * 2**config.depth
    targets = space.step_targets(samples.shapes, samples.truths)
    weights, bias, steps = stage_solves(leaves, n_features, targets, samples.folds, config, n_jobs)
    weights, bias = weights.astype(np.float32), bias.astype(np.float32)
    anchors = np.repeat(np.arange(space.n_points), config.n_ferns)
    stage = FernStage(anchors, offsets, thresholds, weights, bias, config.depth,
                      float(config.radius * space.eye_distance))
    return stage, steps


def fern_leaves(packed: PackedImages, owners: np.ndarray, shapes: np.ndarray, space: ShapeSpace,
                stage: FernStage) -> np.ndarray:
    """Global leaf index (S, T) each sample at ``shapes`` (S, N, 2) reaches in each fern."""
    ab = space.similarity(shapes)
    offsets = stage.offsets.reshape(stage.n_ferns, stage.depth, 4)
    thresholds = stage.thresholds.reshape(stage.n_ferns, stage.depth)
    powers = 1 << np.arange(stage.depth)
    out = np.empty((len(owners), stage.n_ferns), dtype=np.int64)
    for t in range(stage.n_ferns):
        values = packed.differences(owners, shapes[:, stage.anchors[t]], ab, offsets[t])
        out[:, t] = t * 2**stage.depth + (values > thresholds[t]).astype(np.int64) @ powers
    return out


def train_fern_cascade(
    packed: PackedImages, samples: Samples, space: ShapeSpace, stages: Iterable[FernConfig],
    rng: np.random.Generator, n_jobs: int = 1,
    progress: Callable[[Iterable[FernConfig]], Iterable[FernConfig]] | None = None,
) -> list[FernStage]:
    """Learn ``stages`` one after the other, advancing ``samples.shapes`` in place (projected
    onto the shape model after the last stage only, as the fitter does)."""
    configs = list(stages)
    learned = []
    for k, config in enumerate(progress(configs) if progress else configs):
        stage, steps = train_fern_stage(packed, samples, space, config, rng, n_jobs)
        samples.shapes = space.apply_steps(samples.shapes, steps, k == len(configs) - 1)
        learned.append(stage)
    return learned
