"""Learning the fit-quality score of the local-binary cascade, and judging its threshold.

The thesis's failure test (eq. 7.2) bounds the AAM's appearance parameters: it
says nothing of how far a fit is from the face, and it needs the texture warp.
This score is a regression of the fit's error itself: one more fern stage on
pixel differences around the fitted landmarks predicts ``log(NME)`` of the
landmarks it is given. It is learned from shapes put on training faces with
errors from none to far off, and on frames without a face (scored as NME 1).

The threshold is chosen on fits of faces the model was not trained on
(:func:`calibrate`) to keep a share of the good fits (NME < 0.08);
:func:`failure_rates` reports what a threshold keeps and rejects.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aamcore.fitting.algorithm.ferns import FernStage
from aamcore.fitting.shape_space import ShapeSpace
from aamcore.fitting.training.faces import PackedImages
from aamcore.fitting.training.ferns import FernConfig, Samples, grow_ferns, leaf_ridge
from aamcore.fitting.training.perturb import perturbed_starts

GOOD_NME = 0.08
"""A fit below this NME is good: the failure test should keep it."""
BAD_NME = 0.15
"""A fit above this NME (or on no face) has failed: the test should reject it."""
NO_FACE_NME = 1.0
"""The error a shape on an image without a face is scored as."""


@dataclass(frozen=True)
class QualityConfig:
    """How the quality stage is learned.

    Attributes
    ----------
    stage : FernConfig
        Radius, ferns per landmark, depth and candidate pairs; its ridge penalty.
    per_face : int
        Perturbed shapes per training face, their error sizes spread
        log-uniformly by ``spread``.
    spread : (float, float)
        Range of the factor on the base perturbation ``base``.
    base : (5,) floats
        Log scale, angle, x and y shift (fractions of the eye-corner
        distance), shape sd.
    per_no_face : int
        Shapes put on each frame without a face.
    cg_iterations : int
    """

    stage: FernConfig = FernConfig(0.2, n_ferns=2, depth=4, n_pairs=200)
    per_face: int = 3
    spread: tuple[float, float] = (0.2, 12.0)
    base: tuple[float, float, float, float, float] = (0.03, 0.03, 0.04, 0.04, 0.25)
    per_no_face: int = 40
    cg_iterations: int = 60


def nme_of(shapes: np.ndarray, truths: np.ndarray, eye_corners: tuple[int, int] = (36, 45)
           ) -> np.ndarray:
    """NME (S,) of ``shapes`` (S, N, 2) against ``truths`` (S, N, 2): the mean point error
    over the truths' outer-eye-corner distance."""
    iod = np.linalg.norm(truths[:, eye_corners[0]] - truths[:, eye_corners[1]], axis=-1)
    return np.linalg.norm(shapes - truths, axis=-1).mean(axis=-1) / iod


def quality_target(nme: np.ndarray) -> np.ndarray:
    """What the score regresses: ``log(NME)``, NME limited to [0.005, 1]."""
    return np.log(np.clip(nme, 0.005, NO_FACE_NME))


def quality_samples(space: ShapeSpace, truths: np.ndarray, config: QualityConfig,
                    rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Perturbed shapes on the training faces of ``truths`` (F, N, 2): owners (S,),
    shapes (S, N, 2) and their NME (S,)."""
    unit = space.eye_distance
    ls, ang, dx, dy, shape_sd = config.base
    owners = np.repeat(np.arange(len(truths)), config.per_face)
    factor = np.exp(rng.uniform(*np.log(config.spread), size=len(owners)))[:, None]
    sd = np.array([ls, ang, dx * unit, dy * unit]) * factor
    shapes = perturbed_starts(space, truths[owners], np.zeros(4), sd, rng,
                              shape_sd=np.minimum(shape_sd * factor, 2.0))
    return owners, shapes, nme_of(shapes, truths[owners], space.eye_corners)


def train_quality_stage(packed: PackedImages, owners: np.ndarray, shapes: np.ndarray,
                        nme: np.ndarray, space: ShapeSpace, config: QualityConfig,
                        rng: np.random.Generator, n_jobs: int = 1) -> FernStage:
    """Learn the quality stage from shapes (S, N, 2) on the packed images and their NME (S,):
    its output (1,) is the predicted ``log(NME)``."""
    target = quality_target(nme)
    samples = Samples(owners, np.zeros_like(shapes), shapes)
    per_landmark = np.broadcast_to(target[:, None, None], (len(target), space.n_points, 1))
    offsets, thresholds, leaves = grow_ferns(packed, samples, space, per_landmark,
                                             config.stage, rng, n_jobs)
    n_features = leaves.shape[1] * 2**config.stage.depth
    weights, bias = leaf_ridge(leaves, n_features, target[:, None], config.stage.ridge,
                               config.cg_iterations)
    anchors = np.repeat(np.arange(space.n_points), config.stage.n_ferns)
    return FernStage(anchors, offsets, thresholds, weights.astype(np.float32),
                     bias.astype(np.float32), config.stage.depth,
                     float(config.stage.radius * space.eye_distance))


def calibrate(good_scores: np.ndarray, keep: float = 0.99) -> float:
    """Threshold keeping the share ``keep`` of ``good_scores`` (scores of good held-out fits)."""
    return float(np.quantile(np.asarray(good_scores, dtype=np.float64), keep))


def failure_rates(scores: np.ndarray, nme: np.ndarray, threshold: float) -> dict[str, float]:
    """What the test keeps and rejects.

    Returns
    -------
    dict
        ``kept_good``: share of fits with NME < :data:`GOOD_NME` scored at or
        under ``threshold``; ``rejected_bad``: share of fits with NME >
        :data:`BAD_NME` scored above it; ``n_good``, ``n_bad``.
    """
    scores, nme = np.asarray(scores, np.float64), np.asarray(nme, np.float64)
    good, bad = nme < GOOD_NME, nme > BAD_NME
    return {
        "kept_good": float(np.mean(scores[good] <= threshold)) if good.any() else float("nan"),
        "rejected_bad": float(np.mean(scores[bad] > threshold)) if bad.any() else float("nan"),
        "n_good": int(good.sum()),
        "n_bad": int(bad.sum()),
    }
