"""Learning the coarse landmark-HOG stages of the local-binary cascade.

Each stage is one ridge regression from the HOG descriptors at the current
landmarks of the similarity-normalised face
(:class:`~aamcore.fitting.algorithm.local_hog.LandmarkHog`) to the step in the
shape basis; the training samples are advanced in-sample (measured as good on
validation faces as cross-fitting, which is slower).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from aamcore.fitting.algorithm.local_hog import HogStage, LandmarkHog
from aamcore.fitting.shape_space import ShapeSpace
from aamcore.fitting.training.ferns import Samples

CHUNK = 512
"""Samples per thread task while computing descriptors."""


@dataclass(frozen=True)
class HogConfig:
    """One coarse stage: HOG windows of ``window`` px (``cells`` x ``cells`` cells) on a
    canvas where the mean shape's eye corners are ``iod`` px apart."""

    iod: float = 40.0
    window: int = 32
    cells: int = 2


def hog_features(images: Sequence[np.ndarray], owners: np.ndarray, shapes: np.ndarray,
                 extractor: LandmarkHog, n_jobs: int = 1) -> np.ndarray:
    """Landmark HOG descriptors (S, D) float32 of each sample's image at its shape (S, N, 2)."""
    first = extractor(images[owners[0]], shapes[0])
    out = np.empty((len(owners), first.size), dtype=np.float32)

    def work(lo: int) -> None:
        for k in range(lo, min(lo + CHUNK, len(owners))):
            out[k] = extractor(images[owners[k]], shapes[k])

    starts = range(0, len(owners), CHUNK)
    if n_jobs > 1:
        with ThreadPoolExecutor(n_jobs) as pool:
            list(pool.map(work, starts))
    else:
        for lo in starts:
            work(lo)
    return out


def centred_gram(xc: np.ndarray, n_jobs: int = 1) -> np.ndarray:
    """``xc^T xc`` (D, D) float64 of centred float32 descriptors (S, D): float32 products
    (a third of the float64 time; 3e-7 apart in relative terms on the default recipe's
    stages, against a ridge of the mean diagonal), over row blocks in ``n_jobs`` threads."""
    blocks = np.array_split(xc, max(1, n_jobs))
    if len(blocks) == 1:
        return (xc.T @ xc).astype(np.float64)
    with ThreadPoolExecutor(len(blocks)) as pool:
        parts = list(pool.map(lambda b: b.T @ b, blocks))
    return np.sum(parts, axis=0, dtype=np.float64)


def train_hog_stage(images: Sequence[np.ndarray], samples: Samples, space: ShapeSpace,
                    config: HogConfig, ridge: float, n_jobs: int = 1
                    ) -> tuple[HogStage, np.ndarray]:
    """Learn one stage; returns it and the training samples' steps (S, Q).

    ``ridge`` is the penalty as a fraction of the mean diagonal of the centred
    Gram matrix.
    """
    extractor = LandmarkHog(space.mean, config.iod, config.window, config.cells,
                            space.eye_distance)
    x = hog_features(images, samples.owners, samples.shapes, extractor, n_jobs)
    targets = space.step_targets(samples.shapes, samples.truths)
    mu = x.mean(axis=0, dtype=np.float64)
    y_mean = targets.mean(axis=0)
    xc = x - mu.astype(np.float32)
    gram = centred_gram(xc, n_jobs)
    gram[np.diag_indices_from(gram)] += ridge * float(np.trace(gram)) / len(gram)
    weights = np.linalg.solve(gram, (xc.T @ (targets - y_mean).astype(np.float32)).astype(
        np.float64))
    steps = xc @ weights.astype(np.float32) + y_mean
    stage = HogStage(config.iod, config.window, config.cells, mu.astype(np.float32),
                     weights.astype(np.float32), y_mean.astype(np.float32))
    return stage, steps


def train_hog_cascade(
    images: Sequence[np.ndarray], samples: Samples, space: ShapeSpace,
    stages: Iterable[HogConfig], ridge: float, n_jobs: int = 1,
    progress: Callable[[Iterable[HogConfig]], Iterable[HogConfig]] | None = None,
) -> list[HogStage]:
    """Learn the coarse stages one after the other, advancing ``samples.shapes`` in place
    (projected onto the shape model after each stage, as the fitter does)."""
    configs = list(stages)
    learned = []
    for config in progress(configs) if progress else configs:
        stage, steps = train_hog_stage(images, samples, space, config, ridge, n_jobs)
        samples.shapes = space.apply_steps(samples.shapes, steps)
        learned.append(stage)
    return learned
