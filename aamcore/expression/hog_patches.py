"""Histograms of oriented gradients around the landmarks of the canonical face crop.

:func:`hog_block` describes the texture around each inner landmark (brows,
nose, eyes, mouth) of the eye-aligned crop (:func:`~aamcore.expression.crop.aligned_face`);
:func:`mirror_symmetry` compares those patches with their mirror images',
which tells a frontal face from a turned one that the fitter forced into a
frontal shape.
"""

from __future__ import annotations

import cv2
import numpy as np

from aamcore.expression.crop import MIRROR
from aamcore.expression.spec import FeatureConfig

_TINY = 1e-6
HYS_CLIP = 0.2
"""Dalal and Triggs' L2-Hys clipping of the normalised patch vectors."""


def integral_histogram(crop: np.ndarray, bins: int) -> np.ndarray:
    """Integral image of the gradient magnitude per orientation bin.

    Parameters
    ----------
    crop : (H, W) uint8 array
    bins : int
        Unsigned orientation bins over 0-180 degrees.

    Returns
    -------
    (H + 1, W + 1, bins) float64 array
    """
    g = crop.astype(np.float32)
    gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=1)
    gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=1)
    magnitude = np.hypot(gx, gy).astype(np.float64)
    angle = np.mod(np.arctan2(gy, gx), np.pi)
    index = np.minimum((angle * (bins / np.pi)).astype(np.int64), bins - 1)
    planes = np.zeros((*crop.shape, bins))
    np.put_along_axis(planes, index[..., None], magnitude[..., None], axis=2)
    return cv2.integral(planes, sdepth=cv2.CV_64F)


def hog_block(crop: np.ndarray, points: np.ndarray, config: FeatureConfig) -> np.ndarray:
    """HOG of a patch around each of ``config.hog_points``.

    Each patch's cells hold magnitude-weighted histograms of unsigned gradient
    orientation (central differences, ``hog_bins`` bins over 0-180 degrees);
    the patch's vector is L2-normalised, clipped at 0.2 and normalised again
    (L2-Hys). Patches beyond the crop see only its inside. The cell sums come
    from an integral histogram.

    Parameters
    ----------
    crop : (S, S) uint8 array
    points : (68, 2) array
        Landmarks in crop pixels.
    config : FeatureConfig

    Returns
    -------
    (P * cells^2 * bins,) float64 array
        ``P = len(config.hog_points)``.
    """
    integral = integral_histogram(crop, config.hog_bins)
    h, w = crop.shape
    half, cells = config.hog_half, config.hog_cells
    step = 2 * half // cells
    centres = np.round(points[list(config.hog_points)]).astype(np.int64)  # (P, 2)
    edges = np.arange(cells + 1) * step - half
    ys = np.clip(centres[:, 1, None] + edges, 0, h)  # (P, cells + 1)
    xs = np.clip(centres[:, 0, None] + edges, 0, w)
    corners = integral[ys[:, :, None], xs[:, None, :]]  # (P, cells + 1, cells + 1, bins)
    sums = corners[:, 1:, 1:] - corners[:, :-1, 1:] - corners[:, 1:, :-1] + corners[:, :-1, :-1]
    v = np.maximum(sums.reshape(len(centres), -1), 0.0)  # round-off can dip below 0
    v = np.minimum(v / (np.linalg.norm(v, axis=1, keepdims=True) + _TINY), HYS_CLIP)
    return (v / (np.linalg.norm(v, axis=1, keepdims=True) + _TINY)).ravel()


def mirror_symmetry(
    crop: np.ndarray, points: np.ndarray, config: FeatureConfig, own: np.ndarray | None = None
) -> float:
    """How much a face's HOG patches match their mirror images' (1: a symmetric face).

    The mean over :attr:`FeatureConfig.hog_points` of the dot product of
    the (unit) HOG patch of a point in the crop and that of its mirror point
    (:data:`~aamcore.expression.crop.MIRROR`) in the left-right flipped crop.

    Parameters
    ----------
    crop : (S, S) uint8 array
        Canonical crop, equalised as for the HOG.
    points : (68, 2) array
        Landmarks in crop pixels.
    config : FeatureConfig
        Its HOG settings (the thresholds of the quality limits are for the defaults).
    own : (P * cells^2 * bins,) array, optional
        ``hog_block(crop, points, config)`` when already computed.

    Returns
    -------
    float
        In [0, 1].
    """
    own = hog_block(crop, points, config) if own is None else own
    own = own.reshape(len(config.hog_points), -1)
    flipped = points.copy()
    flipped[:, 0] = crop.shape[1] - 1 - flipped[:, 0]
    mirrored = hog_block(np.ascontiguousarray(crop[:, ::-1]), flipped[MIRROR], config)
    return float(np.mean(np.sum(own * mirrored.reshape(own.shape), axis=1)))
