"""Learning the cascade of :class:`~aamcore.fitting.algorithm.SupervisedDescent`."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from aamcore.detection.boxes import landmark_box
from aamcore.detection.mapping import BoxToShapeMapping
from aamcore.fitting.algorithm.supervised_descent import (
    DescentCascade,
    SupervisedDescent,
    model_frame_step,
)
from aamcore.io import FaceSample
from aamcore.model.aam import AAM
from aamcore.model.similarity import Similarity


def _pose_noise(
    starts: list[Similarity], truths: list[Similarity]
) -> tuple[np.ndarray, np.ndarray]:
    """Mean and spread (4,) of how start placements differ from true ones.

    Components: log scale ratio, angle, and x and y shifts in units of the
    true scale (model-frame pixels).
    """
    rows = []
    for s, g in zip(starts, truths, strict=True):
        shift = (s.translation - g.translation) / g.scale
        rows.append([np.log(s.scale / g.scale), s.angle - g.angle, shift[0], shift[1]])
    rows_arr = np.array(rows)
    return rows_arr.mean(axis=0), rows_arr.std(axis=0) + 1e-6


def _perturb(g: Similarity, noise: np.ndarray) -> Similarity:
    return Similarity.from_scale_angle(
        g.scale * np.exp(noise[0]), g.angle + noise[1], g.translation + noise[2:] * g.scale
    )


@dataclass
class _TrainingStarts:
    """The prepared training images and the cascade's starts on them."""

    images: list[np.ndarray]
    truths: list[np.ndarray]
    owners: list[int]
    shapes: list[np.ndarray]


def _starts(
    aam: AAM,
    samples: Sequence[FaceSample],
    boxes: Sequence[np.ndarray | None],
    mapping: BoxToShapeMapping,
    per_image: int,
    noise_scale: float,
    min_spread: tuple[float, float, float, float],
    rng: np.random.Generator,
) -> _TrainingStarts:
    """The real start of each image (its Haar box through ``mapping``) plus random ones."""
    shape_model = aam.shape
    images, truths, real_starts, true_poses, start_poses = [], [], [], [], []
    for sample, box in zip(samples, boxes, strict=True):
        start = (
            mapping.place(box, "detector")
            if box is not None
            else mapping.place(landmark_box(sample.points), "landmarks")
        )
        images.append(aam.prepare_image(sample.load_image(), sample.points))
        truths.append(sample.points)
        real_starts.append(start)
        true_poses.append(shape_model.fit_points(sample.points)[1])
        start_poses.append(shape_model.fit_points(start, iterations=1)[1])
    mean, spread = _pose_noise(start_poses, true_poses)
    width = float(np.ptp(shape_model.mean_shape[:, 0]))
    floor = np.array(min_spread) * [1.0, 1.0, width, width]
    spread = np.maximum(noise_scale * spread, floor)
    owners, shapes = [], []
    for k in range(len(images)):
        owners.append(k)
        shapes.append(real_starts[k])
        for _ in range(per_image - 1):
            sim = _perturb(true_poses[k], mean + spread * rng.standard_normal(4))
            owners.append(k)
            shapes.append(sim.apply(shape_model.mean_shape))
    return _TrainingStarts(images, truths, owners, shapes)


def ridge(x: np.ndarray, y: np.ndarray, strength: float) -> np.ndarray:
    """Ridge regression weights (D, Q) for features ``x`` (S, D) and targets ``y`` (S, Q).

    The penalty is ``strength`` times the mean diagonal of ``x^T x``.
    """
    gram = x.T @ x
    gram[np.diag_indices_from(gram)] += strength * np.trace(gram) / len(gram)
    return np.linalg.solve(gram, x.T @ y)


def train_descent(
    aam: AAM,
    samples: Sequence[FaceSample],
    boxes: Sequence[np.ndarray | None],
    mapping: BoxToShapeMapping,
    stages: int = 5,
    per_image: int = 10,
    hog_cell: int = 12,
    strength: float = 0.05,
    noise_scale: float = 1.25,
    min_spread: tuple[float, float, float, float] = (0.06, 0.06, 0.08, 0.08),
    seed: int = 0,
    progress: Callable[[Iterable[int]], Iterable[int]] | None = None,
) -> DescentCascade:
    """Learn a descent cascade from training ``samples`` and their Haar ``boxes``.

    Parameters
    ----------
    aam : AAM
    samples : sequence of FaceSample
    boxes : sequence of (4,) arrays or None
        The detection matched to each face, None where Haar missed it.
    mapping : BoxToShapeMapping
    stages : int
        Regressions in the cascade.
    per_image : int
        Starts per image: the real one plus random ones.
    hog_cell : int
    strength : float
        Ridge penalty, relative to the features' mean energy.
    noise_scale : float
        Widening of the observed start spread for the random starts.
    min_spread : (4,) floats
        Least spread of the random starts: log scale, angle (radians), x and y
        shifts (fractions of the mean shape's width).
    seed : int
    progress : callable, optional
        Wraps the stages' iteration (a progress bar).
    """
    rng = np.random.default_rng(seed)
    shape_model = aam.shape
    data = _starts(aam, samples, boxes, mapping, per_image, noise_scale, min_spread, rng)
    fitter = SupervisedDescent(aam, DescentCascade([], hog_cell))
    weights: list[np.ndarray] = []
    poses = [shape_model.fit_points(s, iterations=2) for s in data.shapes]
    shapes = [sim.apply(shape_model.instance(b)) for b, sim in poses]
    pairs = list(zip(data.owners, range(len(shapes)), strict=True))
    for _ in progress(range(stages)) if progress else range(stages):
        x = np.stack([fitter.features_at(data.images[k], shapes[j]) for k, j in pairs])
        y = np.stack([
            model_frame_step(fitter.basis, shapes[j], data.truths[k], poses[j][1])
            for k, j in pairs
        ])
        weights.append(ridge(x.astype(np.float64), y, strength).astype(np.float32))
        fitter.weights = weights
        for k, j in pairs:
            target = fitter.step(data.images[k], shapes[j], poses[j][1], len(weights) - 1)
            poses[j] = shape_model.fit_points(target, iterations=2)
            shapes[j] = poses[j][1].apply(shape_model.instance(poses[j][0]))
    return DescentCascade(weights, hog_cell)
