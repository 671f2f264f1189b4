"""Learning the occlusion test: training faces with occluders drawn on them.

Each training face is seen as it is and with :attr:`OcclusionTrainConfig.occluded`
occluders over it, their kinds taken in turn from
:data:`~aamcore.fitting.occluders.KINDS` (a hand, an object, hair,
sunglasses, the frame's edge cutting the face). The landmarks are found as the
stack finds them (the local-binary method from a start on the face's box, when
the model has one; else the annotated landmarks, jittered), the face projected
into the AAM (:class:`~aamcore.fitting.appearance.AppearanceSampler`), and each
landmark's features (:class:`~aamcore.fitting.occlusion.Discs`) labelled by the
share of its part of the face the occluder hides (at the annotated landmarks,
as the benches score it): covered from half of it, visible at none. The
features are standardised per landmark on the unoccluded views, a small
network (scikit-learn) learns covered from visible on three faces in four, and
the threshold is set on the views of the fourth, faces the network never saw,
so that :attr:`OcclusionTrainConfig.false_rate` of their visible landmarks are
flagged; the report gives the rates on both parts.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace

import cv2
import numpy as np

from aamcore.fitting.appearance import AppearanceSampler
from aamcore.fitting.occluders import KINDS, covered_shares, draw_occluder, edge_crop
from aamcore.fitting.occlusion import (
    OcclusionModel,
    inputs,
    logits,
    neighbours,
    probabilities,
)
from aamcore.io import FaceSample
from aamcore.model.aam import AAM

Landmarks = Callable[[np.ndarray, np.ndarray], np.ndarray]
"""``landmarks(image, truth) -> (N, 2)``: how the stack would place a face's landmarks."""
COVERED, VISIBLE = 0.5, 0.0
"""A landmark is covered from this share of its part of the face, visible at this share or
less; those in between (an occluder's edge) are left out of the training."""


@dataclass(frozen=True)
class OcclusionTrainConfig:
    """The recipe.

    Attributes
    ----------
    faces : int
        Training faces read (spread over those given).
    occluded : int
        Occluded views of each face, besides the face as it is.
    false_rate : float
        Share of the visible landmarks of the threshold faces' views it lets be flagged.
    hidden : int
        Units of the first network's hidden layer (per landmark).
    regularisation : float
        L2 penalty of its weights (scikit-learn's ``alpha``).
    context : int
        Units of the second network's hidden layer (all the landmarks' logits).
    context_regularisation : float
        L2 penalty of its weights.
    epochs : int
        Most passes of the optimiser over the training landmarks.
    threshold_share : float
        Share of the faces kept apart to set the threshold on.
    seed : int
    """

    faces: int = 400
    occluded: int = 5
    false_rate: float = 0.02
    hidden: int = 24
    regularisation: float = 1e-3
    context: int = 128
    context_regularisation: float = 0.1
    epochs: int = 200
    threshold_share: float = 0.25
    seed: int = 0


@dataclass
class _Views:
    """Features (V, N, F), landmark covered shares (V, N), clean (V,), face index (V,), the
    occluder's kind (V,)."""

    features: list[np.ndarray]
    shares: list[np.ndarray]
    clean: list[bool]
    face: list[int]
    kind: list[str]
    error: list[float]
    outside: list[np.ndarray]


def _view(aam: AAM, sampler: AppearanceSampler, image: np.ndarray, points: np.ndarray
          ) -> np.ndarray | None:
    """The features (N, F) of ``image`` at ``points``, None where they are not finite."""
    features = sampler.features(aam.prepare_image(image, points), points)
    return features if features is not None and np.all(np.isfinite(features)) else None


def train_occlusion(aam: AAM, samples: Sequence[FaceSample], landmarks: Landmarks | None,
                    config: OcclusionTrainConfig = OcclusionTrainConfig()) -> OcclusionModel:
    """The occlusion test of ``aam``, learned on ``samples`` (see the module notes).

    Parameters
    ----------
    aam : AAM
    samples : sequence of FaceSample
        Training faces, best ones the AAM was not trained on (its residual on them is what
        the stack sees).
    landmarks : callable, optional
        How the stack places the landmarks of a face (:data:`Landmarks`); the annotated
        landmarks jittered by 1 % of the face's width without one.
    config : OcclusionTrainConfig

    Raises
    ------
    ValueError
        With fewer than two samples to learn from.
    """
    chosen = [samples[int(k * len(samples) / config.faces)] for k in range(config.faces)
              ] if len(samples) > config.faces else list(samples)
    if len(chosen) < 2:
        raise ValueError("too few training faces to learn the occlusion test from")
    views = collect_views(aam, chosen, landmarks, config)
    return _fit_model(views, aam, config, len(chosen))


def collect_views(aam: AAM, chosen: Sequence[FaceSample], landmarks: Landmarks | None,
                  config: OcclusionTrainConfig) -> _Views:
    """The features and truth of every view of the ``chosen`` faces."""
    rng = np.random.default_rng(config.seed)
    sampler = AppearanceSampler(aam)
    views = _Views([], [], [], [], [], [], [])
    other = _bgr(chosen[-1].load_image())
    turn = 0
    for index, sample in enumerate(chosen):
        image = _bgr(sample.load_image())
        truth = np.asarray(sample.points, np.float64)
        for k in range(config.occluded + 1):
            shown, where, mask, kind = image, truth, None, "clean"
            if k > 0:
                kind = KINDS[turn % len(KINDS)]
                turn += 1
                if kind == "edge":
                    shown, shift = edge_crop(image, truth, rng)
                    where = truth + shift
                else:
                    shown, mask = draw_occluder(image, truth, rng, kind, other)
            points = _placed(landmarks, shown, where, rng)
            features = _view(aam, sampler, shown, points)
            if features is None:
                continue
            hidden = mask if mask is not None else np.zeros(shown.shape[:2], bool)
            views.features.append(features)
            views.shares.append(covered_shares(hidden, where))
            views.clean.append(k == 0)
            views.face.append(index)
            views.kind.append(kind)
            iod = max(aam.scheme.inter_ocular(where), 1e-6)
            views.error.append(float(np.mean(np.linalg.norm(points - where, axis=1))) / iod)
            height, width = shown.shape[:2]
            views.outside.append((points[:, 0] < 0) | (points[:, 0] > width - 1)
                                 | (points[:, 1] < 0) | (points[:, 1] > height - 1))
        other = image
    return views


def _bgr(image: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image


def _placed(landmarks: Landmarks | None, image: np.ndarray, truth: np.ndarray,
            rng: np.random.Generator) -> np.ndarray:
    if landmarks is not None:
        found = landmarks(image, truth)
        if np.all(np.isfinite(found)):
            return found
    width = float(np.ptp(truth[:, 0]))
    return truth + rng.normal(0, 0.01 * width, truth.shape)


def _rates(scores: np.ndarray, shares: np.ndarray, threshold: float) -> dict[str, float | None]:
    """Shares of the covered and of the visible landmarks flagged."""
    hidden, seen = scores[shares >= COVERED], scores[shares <= VISIBLE]
    return {"covered_flagged": float(np.mean(hidden > threshold)) if hidden.size else None,
            "visible_flagged": float(np.mean(seen > threshold)) if seen.size else None}


def _fit_model(views: _Views, aam: AAM, config: OcclusionTrainConfig,
               n_faces: int) -> OcclusionModel:
    """Standardise, fit the two networks on the training faces, set the threshold on the
    others."""
    from sklearn.exceptions import ConvergenceWarning  # slow imports, training only
    from sklearn.neural_network import MLPClassifier

    F = np.stack(views.features)  # (V, N, F)
    shares = np.stack(views.shares)
    outside = np.stack(views.outside)
    clean = np.array(views.clean)
    face = np.array(views.face)
    apart = (face % max(int(round(1 / config.threshold_share)), 2)) == 0
    if apart.all() or not apart.any():
        apart = np.arange(len(face)) % 2 == 0
    reference = F[clean & ~apart] if (clean & ~apart).sum() > 1 else F
    centre, scale = reference.mean(axis=0), np.maximum(reference.std(axis=0), 1e-3)
    around = neighbours(aam.frame, aam.scheme.n_points)
    n, f, h, g = F.shape[1], F.shape[-1], config.hidden, config.context
    untrained = OcclusionModel(centre, scale, np.zeros((3 * f, h)), np.zeros(h), np.zeros(h),
                               0.0, np.zeros((n, g)), np.zeros(g), np.zeros((g, n)),
                               np.zeros(n), 0.5)
    X = inputs(untrained, F[~apart], around).reshape(-1, 3 * f)
    y = shares[~apart].ravel()
    keep = ((y >= COVERED) | (y <= VISIBLE)) & ~outside[~apart].ravel()
    first = MLPClassifier((h,), alpha=config.regularisation, max_iter=config.epochs,
                          random_state=config.seed, early_stopping=True)
    second = MLPClassifier((g,), alpha=config.context_regularisation,
                           max_iter=2 * config.epochs, random_state=config.seed)
    with warnings.catch_warnings():  # a fixed number of epochs is the recipe
        warnings.simplefilter("ignore", ConvergenceWarning)
        first.fit(X[keep], y[keep] >= COVERED)
        staged = replace(untrained, hidden_weights=first.coefs_[0].astype(np.float64),
                         hidden_bias=first.intercepts_[0].astype(np.float64),
                         output_weights=first.coefs_[1][:, 0].astype(np.float64),
                         output_bias=float(first.intercepts_[1][0]))
        second.fit(logits(staged, F[~apart], around, outside[~apart]),
                   shares[~apart] >= COVERED)
    model = replace(staged, context_weights=second.coefs_[0].astype(np.float64),
                    context_bias=second.intercepts_[0].astype(np.float64),
                    context_output=second.coefs_[1].astype(np.float64),
                    context_output_bias=second.intercepts_[1].astype(np.float64))
    scores = np.where(outside, 1.0, probabilities(model, F, around, outside))
    seen = scores[apart][shares[apart] <= VISIBLE]
    threshold = float(np.quantile(seen, 1.0 - config.false_rate)) if seen.size else 0.5
    report = {"faces": n_faces, "views": len(F), "clean_views": int(clean.sum()),
              "threshold_faces": int(len(set(face[apart].tolist()))),
              "recipe": asdict(config),
              "training": _rates(scores[~apart], shares[~apart], threshold),
              "threshold_views": _rates(scores[apart], shares[apart], threshold)}
    return replace(model, threshold=threshold, report=report)
