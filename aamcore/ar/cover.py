"""Where a hand or an object covers the face: the pixels the glasses are not drawn over.

The fitter flags the landmarks whose texture the AAM cannot explain (occluded,
:mod:`aamcore.fitting.occlusion`). Whatever covers them lies in front of the head, so the
glasses are hidden within a band around each flagged landmark and between flagged
neighbours (a hand is one piece, not a set of dots). A flag alone, with no flagged
neighbour near it, is taken for the occlusion test's noise (about 5% of visible landmarks
are flagged) and hides nothing: a hole punched in the glasses every few frames is worse
than glasses drawn over one fingertip.
"""

from __future__ import annotations

import cv2
import numpy as np

COVER_MM = 10.0
"""Radius of the band around a covered landmark, millimetres at the head's distance: about
the distance from an eye's landmarks to the rim of a lens."""
MIN_NEIGHBOURS = 2
"""Flagged landmarks that must lie within a band's reach of a flagged landmark for it to
hide anything."""


def covered_points(points: np.ndarray, flags: np.ndarray | None) -> np.ndarray | None:
    """The landmarks (k, 2) among ``points`` (N, 2) that ``flags`` (N,) marks occluded; None
    without flags for them (none given, or of another length)."""
    if flags is None or len(flags) != len(points):
        return None
    return np.asarray(points, np.float64)[np.asarray(flags, bool)]


def cover_radius(K: np.ndarray, translation_mm: np.ndarray, mm: float = COVER_MM) -> float:
    """The band's radius in pixels for a head at ``translation_mm`` (3,) seen through ``K``
    (3, 3): ``mm`` at the head's depth."""
    depth = max(float(translation_mm[2]), 1.0)
    return float(K[0, 0]) * mm / depth


def cover_mask(points: np.ndarray, shape: tuple[int, int], radius: float,
               min_neighbours: int = MIN_NEIGHBOURS) -> np.ndarray | None:
    """The covered pixels (H, W) bool of a face, None where nothing is covered.

    Parameters
    ----------
    points : (k, 2) array
        Pixel positions of the landmarks flagged occluded.
    shape : (int, int)
        The frame's height and width.
    radius : float
        The band's radius, pixels (:func:`cover_radius`).
    min_neighbours : int
        Flagged landmarks within ``3 * radius`` a landmark needs to count.
    """
    pts = np.asarray(points, np.float64).reshape(-1, 2)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if len(pts) <= min_neighbours or not radius > 0:
        return None
    distance = np.linalg.norm(pts[:, None] - pts[None], axis=2)
    near = distance <= 3.0 * radius
    kept = near.sum(axis=1) - 1 >= min_neighbours
    if not kept.any():
        return None
    mask = np.zeros(shape, np.uint8)
    r = max(int(round(radius)), 1)
    ij = np.round(pts).astype(np.int32)
    for i in np.flatnonzero(kept):
        cv2.circle(mask, (int(ij[i, 0]), int(ij[i, 1])), r, 1, -1)
        for j in np.flatnonzero(near[i] & kept):
            if j > i:
                cv2.line(mask, (int(ij[i, 0]), int(ij[i, 1])), (int(ij[j, 0]), int(ij[j, 1])),
                         1, 2 * r)
    return mask.astype(bool)
