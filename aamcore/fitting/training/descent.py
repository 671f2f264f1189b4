"""Learning the cascade of :class:`~aamcore.fitting.algorithm.SupervisedDescent`."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from aamcore.detection.mapping import BoxToShapeMapping, landmark_box
from aamcore.fitting.algorithm.supervised_descent import (
    DescentCascade,
    SupervisedDescent,
    model_frame_step,
)
from aamcore.io import FaceSample
from aamcore.model.aam import AAM
from aamcore.model.procrustes import Similarity
from aamcore.model.similarity import apply_pose, pose_from_similarity, similarity_from_pose


def _pose_noise(
    starts: list[np.ndarray], truths: list[np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """Mean and spread (4,) of how start poses differ from true ones.

    Components: log scale ratio, angle, and x and y shifts in units of the
    true scale (model-frame pixels).
    """
    rows = []
    for ts, tg in zip(starts, truths, strict=True):
        s, g = similarity_from_pose(ts), similarity_from_pose(tg)
        shift = (s.translation - g.translation) / g.scale
        rows.append([np.log(s.scale / g.scale), s.angle - g.angle, shift[0], shift[1]])
    rows_arr = np.array(rows)
    return rows_arr.mean(axis=0), rows_arr.std(axis=0) + 1e-6


def _perturb(t: np.ndarray, noise: np.ndarray) -> np.ndarray:
    g = similarity_from_pose(t)
    sim = Similarity(
        g.scale * np.exp(noise[0]), g.angle + noise[1], g.translation + noise[2:] * g.scale
    )
    return pose_from_similarity(sim)


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
) -> DescentCascade:
    """Learn a descent cascade from training ``samples`` and their Haar ``boxes``.

    Parameters
    ----------
    aam : AAM
    samples : sequence of FaceSample
    boxes : sequence of (4,) arrays or None
        The detection matched to each face, None where Haar missed it (the
        landmark-box mapping then gives the start).
    mapping : BoxToShapeMapping
    stages : int
        Regressions in the cascade.
    per_image : int
        Starts per image: the real one plus random ones.
    hog_cell : int
    strength : float
        Ridge penalty, relative to the features' mean energy.
    noise_scale : float
        Widening of the observed start-pose spread for the random starts.
    min_spread : (4,) floats
        Least spread of the random starts: log scale, angle (radians), and x
        and y shifts as fractions of the mean shape's width, so that the
        cascade also learns to recover from starts worse than a good
        detector gives (tracking after fast motion, displaced starts).
    seed : int
    """
    rng = np.random.default_rng(seed)
    shape_model = aam.shape
    images, truths, real_starts, true_poses, start_poses = [], [], [], [], []
    for sample, box in zip(samples, boxes, strict=True):
        image = aam.prepare_image(sample.load_image(), sample.points)
        start = (
            mapping.place(box, "detector")
            if box is not None
            else mapping.place(landmark_box(sample.points), "landmarks")
        )
        images.append(image)
        truths.append(sample.points)
        real_starts.append(start)
        true_poses.append(shape_model.fit_points(sample.points)[1])
        start_poses.append(shape_model.fit_points(start, iterations=1)[1])
    mean, spread = _pose_noise(start_poses, true_poses)
    width = float(np.ptp(shape_model.mean_shape[:, 0]))
    floor = np.array(min_spread) * [1.0, 1.0, width, width]
    spread = np.maximum(noise_scale * spread, floor)
    owners, shapes = [], []
    mean_shape = shape_model.mean_shape
    for k in range(len(images)):
        owners.append(k)
        shapes.append(real_starts[k])
        for _ in range(per_image - 1):
            t = _perturb(true_poses[k], mean + spread * rng.standard_normal(4))
            owners.append(k)
            shapes.append(apply_pose(t, mean_shape))
    fitter = SupervisedDescent(aam, DescentCascade([], hog_cell))
    weights: list[np.ndarray] = []
    poses = [shape_model.fit_points(s, iterations=2) for s in shapes]
    shapes = [apply_pose(t, shape_model.instance(b)) for b, t in poses]
    for _ in range(stages):
        x = np.stack(
            [fitter.features_at(images[k], s) for k, s in zip(owners, shapes, strict=True)]
        )
        y = np.stack(
            [
                model_frame_step(fitter.basis, s, truths[k], t)
                for k, s, (_, t) in zip(owners, shapes, poses, strict=True)
            ]
        )
        w = ridge(x.astype(np.float64), y, strength).astype(np.float32)
        weights.append(w)
        fitter.weights = weights
        new_shapes, new_poses = [], []
        for k, s, (_, t) in zip(owners, shapes, poses, strict=True):
            target = fitter.step(images[k], s, t, len(weights) - 1)
            b, t_new = shape_model.fit_points(target, iterations=2)
            new_shapes.append(apply_pose(t_new, shape_model.instance(b)))
            new_poses.append((b, t_new))
        shapes, poses = new_shapes, new_poses
    return DescentCascade(weights, hog_cell)


def attach_cascade(aam: AAM, cascade: DescentCascade) -> AAM:
    """Store ``cascade`` in ``aam``'s attachments, to be saved with the model."""
    for k, w in enumerate(cascade.weights):
        aam.attachments[f"descent_{k}"] = w
    aam.attachment_header["descent"] = {
        "stages": len(cascade.weights),
        "hog_cell": cascade.hog_cell,
    }
    return aam


def stored_cascade(aam: AAM) -> DescentCascade:
    """The descent cascade stored with ``aam``.

    Raises
    ------
    ValueError
        If the model was saved without one.
    """
    info = aam.attachment_header.get("descent")
    if info is None:
        raise ValueError("this model has no supervised-descent cascade: train it with `--fit`")
    weights = [aam.attachments[f"descent_{k}"] for k in range(int(info["stages"]))]
    return DescentCascade(weights, int(info["hog_cell"]))
