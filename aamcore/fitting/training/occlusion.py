"""Learning the occlusion test: training faces with occluders drawn on them.

Each training face is seen as it is and with :attr:`OcclusionTrainConfig.occluded`
occluders drawn over it (:func:`draw_occluder`: hand-like groups of
ellipses, polygons and bars, filled with a flat colour near the face's own,
a colour ramp, or a patch of another photograph, with soft or hard edges).
The landmarks are found as the stack finds them (the local-binary method
from a start on the face's box, when the model has one; else the annotated
landmarks, jittered), the face projected into the AAM
(:class:`~aamcore.fitting.appearance.AppearanceSampler`), and each
triangle's features (:class:`~aamcore.fitting.occlusion.TriangleFeatures`)
labelled by the share of it the drawn occluder covers. The features are
standardised per triangle on the unoccluded views, a logistic model
(scikit-learn) learns covered from not, and the landmark threshold is set so
that :attr:`OcclusionTrainConfig.false_rate` of the visible landmarks of the
training views are flagged.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass

import cv2
import numpy as np

from aamcore.fitting.appearance import AppearanceSampler
from aamcore.fitting.occlusion import (
    OcclusionModel,
    TriangleFeatures,
    inputs,
    landmark_weights,
    neighbours,
    probabilities,
)
from aamcore.fitting.result import AAMFit, LandmarkFit
from aamcore.io import FaceSample
from aamcore.model.aam import AAM
from aamcore.model.similarity import Similarity

Landmarks = Callable[[np.ndarray, np.ndarray], np.ndarray]
"""``landmarks(image, truth) -> (N, 2)``: how the stack would place a face's landmarks."""
COVERED, VISIBLE = 0.5, 0.05
"""A triangle (or landmark) is covered above this share, visible below the other; those
in between are left out of the training."""


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
        Share of the training views' visible landmarks the threshold lets be flagged.
    hidden : int
        Units of the network's hidden layer.
    regularisation : float
        L2 penalty of the network's weights (scikit-learn's ``alpha``).
    epochs : int
        Most passes of the optimiser over the training triangles.
    seed : int
    """

    faces: int = 300
    occluded: int = 3
    false_rate: float = 0.02
    hidden: int = 16
    regularisation: float = 1e-3
    epochs: int = 200
    seed: int = 0


def _fill(mask_box: tuple[int, int, int, int], face_colour: np.ndarray, other: np.ndarray,
          rng: np.random.Generator) -> np.ndarray:
    """What the occluder looks like over ``mask_box`` (x0, y0, x1, y1): (h, w, 3) float32."""
    x0, y0, x1, y1 = mask_box
    h, w = y1 - y0, x1 - x0
    kind = rng.integers(3)
    if kind == 0:  # a flat colour near the face's own (a hand, a sleeve)
        colour = np.clip(face_colour * rng.uniform(0.7, 1.3, 3) + rng.normal(0, 10, 3), 0, 255)
        out = np.broadcast_to(colour, (h, w, 3)).astype(np.float32)
        return out + rng.normal(0, rng.uniform(0, 4), (h, w, 3)).astype(np.float32)
    if kind == 1:  # a ramp between two colours
        a, b = rng.uniform(0, 255, 3), rng.uniform(0, 255, 3)
        ramp = np.linspace(0, 1, max(w, 1), dtype=np.float32)[None, :, None]
        return np.broadcast_to(a + (b - a) * ramp, (h, w, 3)).astype(np.float32)
    oh, ow = other.shape[:2]  # a patch of another photograph (patterned cloth, a hand, hair)
    sx, sy = rng.integers(0, max(ow - w, 1)), rng.integers(0, max(oh - h, 1))
    patch = other[sy:sy + h, sx:sx + w]
    return cv2.resize(patch, (w, h)).astype(np.float32)


def draw_occluder(image: np.ndarray, points: np.ndarray, other: np.ndarray,
                  rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """``image`` (H, W, 3) uint8 with a random occluder over part of the face at ``points``
    (N, 2), and the occluder's mask (H, W) bool; ``other`` (h, w, 3) lends its pixels to a
    patterned occluder."""
    height, width = image.shape[:2]
    lo, hi = points.min(axis=0), points.max(axis=0)
    face = float(hi[0] - lo[0])
    mask = np.zeros((height, width), np.uint8)
    centre = points[rng.integers(len(points))] + rng.normal(0, 0.1 * face, 2)
    size = face * rng.uniform(0.2, 0.55)
    shape = rng.integers(3)
    if shape == 0:  # a hand: a palm and a few fingers
        angle = rng.uniform(0, 180)
        cv2.ellipse(mask, _pt(centre), _axes(size, size * rng.uniform(0.6, 1.2)), angle, 0, 360,
                    255, -1)
        direction = np.array([np.cos(np.radians(angle)), np.sin(np.radians(angle))])
        across = np.array([-direction[1], direction[0]])
        for k in range(int(rng.integers(0, 5))):
            tip = centre + direction * size * 1.1 + across * size * (0.5 - 0.3 * k)
            cv2.ellipse(mask, _pt(tip), _axes(size * 0.55, size * 0.15), angle, 0, 360, 255, -1)
    elif shape == 1:  # a polygon
        n = int(rng.integers(3, 8))
        angles = np.sort(rng.uniform(0, 2 * np.pi, n))
        radii = size * rng.uniform(0.5, 1.0, n)
        corners = centre + np.stack([np.cos(angles), np.sin(angles)], axis=1) * radii[:, None]
        cv2.fillPoly(mask, [np.round(corners).astype(np.int32)], 255)
    else:  # a bar: a microphone, a pen, a strap
        angle = rng.uniform(0, np.pi)
        half = np.array([np.cos(angle), np.sin(angle)]) * face
        cv2.line(mask, _pt(centre - half), _pt(centre + half), 255,
                 max(int(size * rng.uniform(0.2, 0.6)), 2))
    ys, xs = np.nonzero(mask)
    if len(xs) == 0:
        return image.copy(), mask > 0
    box = (int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1)
    inside = points_colour(image, points)
    fill = _fill(box, inside, other, rng)
    soft = rng.uniform(0, 2.5)
    alpha = mask.astype(np.float32) / 255
    if soft > 0.3:
        alpha = cv2.GaussianBlur(alpha, (0, 0), soft)
    out = image.astype(np.float32)
    x0, y0, x1, y1 = box
    a = alpha[y0:y1, x0:x1, None]
    out[y0:y1, x0:x1] = out[y0:y1, x0:x1] * (1 - a) + fill * a
    return np.clip(out, 0, 255).astype(np.uint8), alpha > 0.5


def _pt(p: np.ndarray) -> tuple[int, int]:
    return int(round(float(p[0]))), int(round(float(p[1])))


def _axes(a: float, b: float) -> tuple[int, int]:
    return max(int(a), 1), max(int(b), 1)


def points_colour(image: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The mean colour (3,) of the face's landmark box."""
    lo = np.maximum(np.floor(points.min(axis=0)).astype(int), 0)
    hi = np.maximum(np.ceil(points.max(axis=0)).astype(int), lo + 1)
    region = image[lo[1]:hi[1], lo[0]:hi[0]].reshape(-1, image.shape[2] if image.ndim == 3 else 1)
    return region.mean(axis=0) if len(region) else np.full(3, 128.0)


@dataclass
class _Views:
    """Features (V, T, K), triangle covered shares (V, T), landmark shares (V, N), clean (V,)."""

    features: list[np.ndarray]
    triangles: list[np.ndarray]
    landmarks: list[np.ndarray]
    clean: list[bool]


def _view(aam: AAM, sampler: AppearanceSampler, features: TriangleFeatures,
          weights: np.ndarray, image: np.ndarray, mask: np.ndarray, points: np.ndarray,
          views: _Views, clean: bool) -> None:
    prepared = aam.prepare_image(image, points)
    found = sampler.project(prepared, points)
    if not np.all(np.isfinite(found.c)):
        return
    fit = AAMFit.of_landmarks(LandmarkFit(points, Similarity()), found.c, found.residual,
                              found.error, texture=found.texture)
    covered = aam.warp.warp(mask.astype(np.uint8) * 255, points).astype(np.float64)
    if covered.ndim == 2:
        covered = covered.mean(axis=1)
    share = features.triangle_means(covered / 255.0)
    views.features.append(features(fit))
    views.triangles.append(share)
    views.landmarks.append(weights @ share)
    views.clean.append(clean)


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
        With no sample to learn from.
    """
    rng = np.random.default_rng(config.seed)
    chosen = [samples[int(k * len(samples) / config.faces)] for k in range(config.faces)
              ] if len(samples) > config.faces else list(samples)
    if not chosen:
        raise ValueError("no training face to learn the occlusion test from")
    sampler = AppearanceSampler(aam)
    features = TriangleFeatures(aam)
    weights = landmark_weights(aam.frame, aam.scheme.n_points)
    views = _Views([], [], [], [])
    other = chosen[-1].load_image()
    for sample in chosen:
        image = _bgr(sample.load_image())
        truth = np.asarray(sample.points, np.float64)
        for k in range(config.occluded + 1):
            shown, mask = (image, np.zeros(image.shape[:2], bool)) if k == 0 else \
                draw_occluder(image, truth, _bgr(other), rng)
            points = _placed(landmarks, shown, truth, rng)
            _view(aam, sampler, features, weights, shown, mask, points, views, k == 0)
        other = image
    return _fit_model(views, aam, weights, config, len(chosen))


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


def _fit_model(views: _Views, aam: AAM, weights: np.ndarray, config: OcclusionTrainConfig,
               n_faces: int) -> OcclusionModel:
    """Standardise, fit the network, set the landmark threshold."""
    from sklearn.exceptions import ConvergenceWarning  # slow imports, training only
    from sklearn.neural_network import MLPClassifier

    F = np.stack(views.features)  # (V, T, K)
    shares = np.stack(views.triangles)
    clean = np.array(views.clean)
    centre = F[clean].mean(axis=0)
    scale = np.maximum(F[clean].std(axis=0), 1e-3)
    around = neighbours(aam.frame)
    k, h = F.shape[-1], config.hidden
    unfitted = OcclusionModel(centre, scale, np.zeros((3 * k, h)), np.zeros(h), np.zeros(h),
                              0.0, 0.5)
    X = inputs(unfitted, F, around)
    covered, visible = shares > COVERED, shares < VISIBLE
    keep = covered | visible
    net = MLPClassifier((h,), alpha=config.regularisation, max_iter=config.epochs,
                        random_state=config.seed, early_stopping=True)
    with warnings.catch_warnings():  # a fixed number of epochs is the recipe
        warnings.simplefilter("ignore", ConvergenceWarning)
        net.fit(X[keep], covered[keep])
    model = OcclusionModel(centre, scale, net.coefs_[0].astype(np.float64),
                           net.intercepts_[0].astype(np.float64),
                           net.coefs_[1][:, 0].astype(np.float64), float(net.intercepts_[1][0]),
                           0.5)
    scores = probabilities(model, F, around) @ weights.T
    landmark_share = np.stack(views.landmarks)
    seen, hidden = scores[landmark_share < VISIBLE], scores[landmark_share > COVERED]
    threshold = float(np.quantile(seen, 1.0 - config.false_rate)) if seen.size else 0.5
    report = {"faces": n_faces, "views": len(F), "clean_views": int(clean.sum()),
              "recipe": asdict(config),
              "training_covered_flagged": float(np.mean(hidden > threshold)) if hidden.size
              else None,
              "training_visible_flagged": float(np.mean(seen > threshold)) if seen.size
              else None}
    return OcclusionModel(centre, scale, model.hidden_weights, model.hidden_bias,
                          model.output_weights, model.output_bias, threshold, report)
