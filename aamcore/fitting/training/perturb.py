"""Training starts of the local-binary cascade: shapes moved about the truth as real starts are."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from aamcore.fitting.shape_space import ShapeSpace


def similarity_params(space: ShapeSpace, shapes: np.ndarray) -> np.ndarray:
    """``(log scale, angle, cx, cy)`` (S, 4) of the similarity from the mean to each shape
    (S, N, 2)."""
    ab = space.similarity(shapes)
    centre = shapes.mean(axis=1)
    return np.column_stack([np.log(np.hypot(ab[:, 0], ab[:, 1])),
                            np.arctan2(ab[:, 1], ab[:, 0]), centre])


def place(model_shapes: np.ndarray, params: np.ndarray) -> np.ndarray:
    """Model-frame shapes (S, N, 2) put in the image by ``(log scale, angle, cx, cy)`` (S, 4)."""
    s = np.exp(params[:, 0])
    a, b = (s * np.cos(params[:, 1]))[:, None], (s * np.sin(params[:, 1]))[:, None]
    x = model_shapes[..., 0] * a - model_shapes[..., 1] * b
    y = model_shapes[..., 0] * b + model_shapes[..., 1] * a
    return np.stack([x, y], axis=-1) + params[:, None, 2:4]


def start_noise(space: ShapeSpace, starts: np.ndarray, truths: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """Mean and sd (4,) of how ``starts`` (S, N, 2) differ from the ``truths`` (S, N, 2).

    Components: log scale ratio, angle and the two shifts of the centroid in
    units of the true scale (model-frame units).
    """
    ps, pt = similarity_params(space, starts), similarity_params(space, truths)
    rel = np.column_stack([ps[:, 0] - pt[:, 0], ps[:, 1] - pt[:, 1],
                           (ps[:, 2:] - pt[:, 2:]) / np.exp(pt[:, :1])])
    return rel.mean(axis=0), rel.std(axis=0) + 1e-6


def _shape_noise(space: ShapeSpace, truths: np.ndarray, shape_sd: np.ndarray | float,
                 rng: np.random.Generator) -> np.ndarray:
    """Model-frame shapes (S, N, 2) of the ``truths`` (S, N, 2), their shape parameters
    moved by ``shape_sd`` sd (limited to 3 sd)."""
    ab = space.similarity(truths)
    a, b = ab[:, 0, None], ab[:, 1, None]
    rel = truths - truths.mean(axis=1, keepdims=True)
    s2 = a * a + b * b
    model = np.stack([(rel[..., 0] * a + rel[..., 1] * b) / s2,
                      (-rel[..., 0] * b + rel[..., 1] * a) / s2], -1)
    coef = (model - space.mean).reshape(len(truths), -1) @ space.modes
    coef = coef + shape_sd * (space.limits / 3.0) * rng.standard_normal(coef.shape)
    coef = np.clip(coef, -space.limits, space.limits)
    return space.mean + (coef @ space.modes.T).reshape(truths.shape)


def perturbed_starts(
    space: ShapeSpace,
    truths: np.ndarray,
    mean: np.ndarray,
    sd: np.ndarray,
    rng: np.random.Generator,
    shape_sd: np.ndarray | float | None = None,
) -> np.ndarray:
    """Starts (S, N, 2) around ``truths`` (S, N, 2) with similarity noise ``N(mean, sd)``.

    ``mean`` and ``sd`` (4,) or (S, 4) are in :func:`start_noise`'s units.
    Without ``shape_sd`` the start is the mean shape (a start from a detection);
    with it the true shape itself, its parameters moved by ``shape_sd`` sd (the
    previous frame's landmarks).
    """
    pt = similarity_params(space, truths)
    noise = mean + sd * rng.standard_normal((len(truths), 4))
    params = np.column_stack([pt[:, 0] + noise[:, 0], pt[:, 1] + noise[:, 1],
                              pt[:, 2:] + noise[:, 2:] * np.exp(pt[:, :1])])
    if shape_sd is None:
        model_shapes = np.broadcast_to(space.mean, truths.shape)
    else:
        model_shapes = _shape_noise(space, truths, shape_sd, rng)
    return place(model_shapes, params)


def placed_on_no_face(
    space: ShapeSpace, sizes: Sequence[tuple[int, int]], per_image: int,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """Mean shapes put at random places, sizes and angles on images of ``sizes`` (w, h).

    Returns the owners (S,) and the shapes (S, N, 2).
    """
    owners, shapes = [], []
    width = float(np.ptp(space.mean[:, 0]))
    for k, (w, h) in enumerate(sizes):
        for _ in range(per_image):
            face = rng.uniform(0.1, 0.5) * min(w, h)
            s, angle = face / width, rng.normal(0.0, 0.25)
            a, b = s * np.cos(angle), s * np.sin(angle)
            centre = rng.uniform([0.15 * w, 0.15 * h], [0.85 * w, 0.85 * h])
            shapes.append(space.mean @ np.array([[a, b], [-b, a]]) + centre)
            owners.append(k)
    return np.array(owners, dtype=np.int64), np.stack(shapes)
