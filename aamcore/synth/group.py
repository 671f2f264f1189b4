"""Scenes of several faces with exact landmarks and identities: annotated photos pasted into
one frame, each moving on a path of its own, in front of or behind the others, entering
and leaving.

Each face is its photo placed by a similarity (scale to a face width, then along its
path) under a feathered ellipse around its landmarks, drawn in order: a later face is in
front. A face's truth on a frame is its placed landmarks; it is *in view* when every
landmark is inside the frame and at most :data:`COVERED` of them lie under a face in
front.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from aamcore.model.similarity import Similarity

COVERED = 0.1
"""A face with more than this share of its landmarks under a face in front is not in view."""


@dataclass(frozen=True)
class FacePath:
    """Where one face is over a scene.

    Attributes
    ----------
    keys : (K, 3) floats
        Key frames ``frame, x, y``: the face's landmark centre, in pixels, moving in a
        straight line between them; before the first key and after the last the face is
        absent.
    width : float
        Width of its landmarks' box, pixels.
    """

    keys: tuple[tuple[float, float, float], ...]
    width: float = 120.0

    def at(self, k: int) -> np.ndarray | None:
        """The centre on frame ``k`` (None: absent)."""
        keys = np.asarray(self.keys, np.float64)
        if not keys[0, 0] <= k <= keys[-1, 0]:
            return None
        return np.array([np.interp(k, keys[:, 0], keys[:, 1]),
                         np.interp(k, keys[:, 0], keys[:, 2])])


@dataclass(frozen=True, eq=False)
class GroupScene:
    """A generated scene.

    Attributes
    ----------
    frames : list of (H, W, 3) uint8 arrays
    truths : (F, P, N, 2) float array
        Every face's landmarks on every frame (NaN where it is absent).
    in_view : (F, P) bool array
        Whether each face is in view (:data:`COVERED`).
    crossing : (F, P) bool array
        Whether each face overlaps another present face (landmark boxes, any share).
    """

    frames: list[np.ndarray]
    truths: np.ndarray
    in_view: np.ndarray
    crossing: np.ndarray


def _ellipse_mask(points: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """A feathered ellipse (H, W) float32 over a face's landmarks and forehead."""
    x0, y0 = points.min(axis=0)
    x1, y1 = points.max(axis=0)
    w, h = x1 - x0, y1 - y0
    mask = np.zeros(shape, np.float32)
    centre = (int(round((x0 + x1) / 2)), int(round(y0 + 0.38 * h)))
    axes = (int(round(0.72 * w)), int(round(0.95 * h)))
    cv2.ellipse(mask, centre, axes, 0.0, 0.0, 360.0, 1.0, -1)
    sigma = max(0.06 * w, 1.0)
    return cv2.GaussianBlur(mask, (0, 0), sigma)


def _boxes_overlap(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(a[:, 0].min() < b[:, 0].max() and b[:, 0].min() < a[:, 0].max()
                and a[:, 1].min() < b[:, 1].max() and b[:, 1].min() < a[:, 1].max())


def group_scene(photos: list[tuple[np.ndarray, np.ndarray]], paths: list[FacePath],
                frames: int, size: tuple[int, int] = (960, 540), seed: int = 0,
                noise: float = 2.0) -> GroupScene:
    """A scene of ``photos`` (each ``(H, W, 3)`` uint8 and its landmarks ``(N, 2)``) moving on
    ``paths`` (one each, the later ones in front) for ``frames`` frames of ``size``
    (width, height)."""
    if len(photos) != len(paths) or not photos:
        raise ValueError(f"{len(photos)} photos for {len(paths)} paths")
    width, height = size
    rng = np.random.default_rng(seed)
    first = photos[0][0]
    background = cv2.resize(cv2.GaussianBlur(first, (0, 0), 30), size)
    n_points = photos[0][1].shape[0]
    truths = np.full((frames, len(photos), n_points, 2), np.nan)
    in_view = np.zeros((frames, len(photos)), bool)
    out = []
    for k in range(frames):
        frame = background.astype(np.float32)
        masks: list[np.ndarray | None] = []
        for i, ((photo, points), path) in enumerate(zip(photos, paths, strict=True)):
            centre = path.at(k)
            if centre is None:
                masks.append(None)
                continue
            scale = path.width / max(float(np.ptp(points[:, 0])), 1.0)
            place = Similarity(scale, 0.0, *(centre - scale * points.mean(axis=0)))
            truth = place.apply(points)
            face = cv2.warpAffine(photo, place.matrix, size, flags=cv2.INTER_LINEAR)
            mask = _ellipse_mask(truth, (height, width))[..., None]
            frame = mask * face.astype(np.float32) + (1.0 - mask) * frame
            truths[k, i] = truth
            masks.append(mask[..., 0])
        for i in range(len(photos)):
            truth = truths[k, i]
            if np.isnan(truth).any():
                continue
            inside = ((truth >= 0) & (truth < (width, height))).all()
            xs = np.clip(truth[:, 0].round().astype(int), 0, width - 1)
            ys = np.clip(truth[:, 1].round().astype(int), 0, height - 1)
            front = [m for m in masks[i + 1:] if m is not None]
            covered = max((float((m[ys, xs] > 0.5).mean()) for m in front), default=0.0)
            in_view[k, i] = bool(inside and covered <= COVERED)
        if noise:
            frame += rng.normal(0.0, noise, frame.shape)
        out.append(np.clip(frame, 0, 255).astype(np.uint8))
    crossing = np.zeros_like(in_view)
    for k in range(frames):
        present = [i for i in range(len(photos)) if not np.isnan(truths[k, i]).any()]
        for i in present:
            crossing[k, i] = any(_boxes_overlap(truths[k, i], truths[k, j])
                                 for j in present if j != i)
    return GroupScene(out, truths, in_view, crossing)
