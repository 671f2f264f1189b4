"""Histograms of oriented gradients around the landmarks of the canonical face crop.

:func:`hog_block` describes the texture around each inner landmark (brows,
nose, eyes, mouth) of the eye-aligned crop (:func:`~aamcore.expression.crop.aligned_face`);
:func:`mirror_symmetry` compares those patches with their mirror images',
which tells a frontal face from a turned one that the fitter forced into a
frontal shape.
"""

from __future__ import annotations

from functools import lru_cache

import cv2
import numpy as np

from aamcore.expression.crop import MIRROR
from aamcore.expression.spec import FeatureConfig

_TINY = 1e-6
HYS_CLIP = 0.2
"""Dalal and Triggs' L2-Hys clipping of the normalised patch vectors."""


def _planes(gx: np.ndarray, gy: np.ndarray, bins: int) -> np.ndarray:
    """The plane (:func:`integral_histogram`) of each gradient ``gx``, ``gy`` (float32
    arrays of one shape); an intp array of that shape."""
    # floor(theta * bins / 180) without an arctangent: the number of bin edges (0, 180)
    # that the gradient, turned into the upper half-plane, lies at or beyond.
    ux, uy = np.where(gy < 0, -gx, gx), np.abs(gy)
    index = np.zeros(gx.shape, np.intp)
    for edge in np.arange(1, bins) * (np.pi / bins):
        index += uy * np.float32(np.cos(edge)) - ux * np.float32(np.sin(edge)) >= 0
    index[gx == 0] = bins + 1
    index[gy == 0] = bins
    return index


_SPAN = 511
"""Central differences of uint8 pixels: the integers -255 to 255."""


@lru_cache(maxsize=8)
def _plane_table(bins: int) -> np.ndarray:
    """The plane (uint8) of every integer gradient, by ``(gx + 255) * 511 + gy + 255``:
    what :func:`_planes` gives for it, so that a uint8 crop's gradients are looked up, not
    binned per pixel."""
    values = np.arange(-255, 256, dtype=np.float32)
    gx, gy = np.meshgrid(values, values, indexing="ij")
    plane = _planes(gx, gy, bins).astype(np.uint8).ravel()
    plane.setflags(write=False)
    return plane


def _window_integral(crop: np.ndarray, bins: int, rows: tuple[int, int], cols: tuple[int, int]
                     ) -> np.ndarray:
    """:func:`integral_histogram` of the crop's pixels ``rows[0]:rows[1]``,
    ``cols[0]:cols[1]`` (the gradients are the whole crop's); (rows + 1, cols + 1, bins + 2).

    Every sum is exact (float32 magnitudes, each 0 or at least 1 and below 361, add up
    without rounding in float64 over any crop of fewer than 2^22 pixels), so a rectangle's
    sum is the same read from any window that holds it."""
    (y0, y1), (x0, x1) = rows, cols
    if crop.dtype == np.uint8:
        dx = cv2.Sobel(crop, cv2.CV_16S, 1, 0, ksize=1)[y0:y1, x0:x1]
        dy = cv2.Sobel(crop, cv2.CV_16S, 0, 1, ksize=1)[y0:y1, x0:x1]
        key = dx.astype(np.int32)
        key *= _SPAN
        key += dy
        key += 255 * _SPAN + 255
        index = np.take(_plane_table(bins), key)
        gx, gy = dx.astype(np.float32), dy.astype(np.float32)
    else:
        g = crop.astype(np.float32)
        gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=1)[y0:y1, x0:x1]
        gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=1)[y0:y1, x0:x1]
        index = _planes(gx, gy, bins)
    magnitude = np.sqrt(gx * gx + gy * gy)  # not cv2.magnitude: its result varies in the
    # last bit with the array's alignment
    shape = index.shape
    planes = np.zeros(index.size * (bins + 2), np.float32)  # float32: 7 times faster below
    planes[_offsets(index.size, bins + 2) + index.ravel()] = magnitude.ravel()
    return cv2.integral(planes.reshape(*shape, bins + 2), sdepth=cv2.CV_64F)


@lru_cache(maxsize=16)
def _offsets(n: int, step: int) -> np.ndarray:
    """``arange(n) * step``, made once."""
    out = np.arange(n, dtype=np.intp) * step
    out.setflags(write=False)
    return out


def integral_histogram(crop: np.ndarray, bins: int) -> np.ndarray:
    """Integral image of the gradient magnitude per orientation bin, with the horizontal and
    vertical gradients apart.

    A pixel of unsigned orientation ``theta`` in [0, 180) degrees falls in bin
    ``b = floor(theta * bins / 180)``; in the mirror image its orientation is
    ``180 - theta``, bin ``bins - 1 - b``, except for horizontal gradients (``theta = 0``,
    bin 0 in both) and vertical ones (``theta = 90``, bin ``bins // 2`` in both), which two
    planes of their own hold: so the mirror image's histograms are read from these
    (:func:`hog_pair`).

    Parameters
    ----------
    crop : (H, W) uint8 array
    bins : int
        Unsigned orientation bins over 0-180 degrees.

    Returns
    -------
    (H + 1, W + 1, bins + 2) float64 array
        Planes 0 to ``bins - 1``: the bins without the horizontal and vertical gradients;
        plane ``bins``: the horizontal gradients, plane ``bins + 1`` the vertical ones.
    """
    return _window_integral(crop, bins, (0, crop.shape[0]), (0, crop.shape[1]))


def _corners(cx: np.ndarray, cy: np.ndarray, config: FeatureConfig, shape: tuple[int, ...]
             ) -> tuple[np.ndarray, np.ndarray]:
    """The integral image's rows and columns (P, cells + 1) of the cell corners of the
    patches centred at (cx, cy) (P,) of an image of ``shape``, clipped to it."""
    h, w = shape[:2]
    half, cells = config.hog_half, config.hog_cells
    edges = np.arange(cells + 1) * (2 * half // cells) - half
    ys = np.minimum(np.maximum(cy[:, None] + edges, 0), h)
    xs = np.minimum(np.maximum(cx[:, None] + edges, 0), w)
    return ys, xs


def _cell_sums(integral: np.ndarray, ys: np.ndarray, xs: np.ndarray) -> np.ndarray:
    """Cell histograms (P, cells, cells, bins + 2) of the cells with corners at rows ``ys``
    and columns ``xs`` (P, cells + 1) of ``integral`` (negated where the columns descend)."""
    planes = integral.shape[-1]
    flat = ys[:, :, None] * integral.shape[1] + xs[:, None, :]
    # integral[ys[:, :, None], xs[:, None, :]], (P, cells + 1, cells + 1, bins + 2), by one take
    corners = np.take(integral.reshape(-1, planes), flat, axis=0)
    return corners[:, 1:, 1:] - corners[:, :-1, 1:] - corners[:, 1:, :-1] + corners[:, :-1, :-1]


def _hys(v: np.ndarray, sums: np.ndarray) -> np.ndarray:
    """L2-Hys rows (P, cells^2 * bins) of the cell histograms ``v`` (P, cells, cells, bins)
    in their bins' order (a copy, changed), the horizontal and vertical planes of ``sums``
    (P, cells, cells, bins + 2) added to their bins."""
    bins = v.shape[-1]
    v[..., 0] += sums[..., bins]
    v[..., bins // 2] += sums[..., bins + 1]
    v = np.maximum(v.reshape(len(v), -1), 0.0)  # round-off can dip below 0
    v = np.minimum(v / (_norms(v) + _TINY), HYS_CLIP)
    return v / (_norms(v) + _TINY)


def _norms(v: np.ndarray) -> np.ndarray:
    """The rows' L2 norms (n, 1) of ``v`` (n, d): :func:`numpy.linalg.norm`'s arithmetic,
    without its overhead."""
    return np.sqrt(np.add.reduce(v * v, axis=1, keepdims=True))


def hog_pair(crop: np.ndarray, points: np.ndarray, config: FeatureConfig
             ) -> tuple[np.ndarray, np.ndarray]:
    """HOG of a patch around each of ``config.hog_points``, in the crop and in its mirror
    image (around the mirror points, :data:`~aamcore.expression.crop.MIRROR`), from one
    integral histogram.

    Each patch's cells hold magnitude-weighted histograms of unsigned gradient
    orientation (central differences, ``hog_bins`` bins over 0-180 degrees);
    the patch's vector is L2-normalised, clipped at 0.2 and normalised again
    (L2-Hys). Patches beyond the crop see only its inside.

    Parameters
    ----------
    crop : (S, S) uint8 array
    points : (68, 2) array
        Landmarks in crop pixels.
    config : FeatureConfig

    Returns
    -------
    own, mirrored : (P * cells^2 * bins,) float64 arrays
        ``P = len(config.hog_points)``; ``mirrored`` is :func:`hog_block` of the left-right
        flipped crop at the flipped, mirror-numbered landmarks.
    """
    n, width = len(config.hog_points), crop.shape[1]
    # the own patches' centres, then the mirror patches' (in the mirror image's columns)
    centres = points[_pair_rows(config.hog_points)]
    centres[n:, 0] = width - 1 - centres[n:, 0]
    cx, cy = np.round(centres).astype(np.int64).T
    ys, xs = _corners(cx, cy, config, crop.shape)
    # column c of the mirror image is column w - 1 - c of the crop: its integral's columns
    # w - x, descending, so that the mirror patches' sums come out negated
    xs[n:] = width - xs[n:]
    rows, cols = _window(ys, xs, crop.shape)
    integral = _window_integral(crop, config.hog_bins, rows, cols)
    sums = _cell_sums(integral, ys - rows[0], xs - cols[0])
    np.negative(sums[n:], out=sums[n:])
    bins = config.hog_bins
    v = np.concatenate([sums[:n, ..., :bins], sums[n:, ..., bins - 1::-1]])
    v = _hys(v, sums)
    return v[:n].ravel(), v[n:].ravel()


@lru_cache(maxsize=8)
def _pair_rows(chosen: tuple[int, ...]) -> np.ndarray:
    """The landmarks (2 P,) of the patches, then of their mirror partners
    (:data:`~aamcore.expression.crop.MIRROR`), made once."""
    rows = np.concatenate([np.array(chosen, np.intp), MIRROR[list(chosen)].astype(np.intp)])
    rows.setflags(write=False)
    return rows


def _window(ys: np.ndarray, xs: np.ndarray, shape: tuple[int, ...]
            ) -> tuple[tuple[int, int], tuple[int, int]]:
    """The crop's rows and columns (start, stop) whose integral holds the corners at rows
    ``ys`` and columns ``xs``: at least one pixel."""
    y0, y1, x0, x1 = int(ys.min()), int(ys.max()), int(xs.min()), int(xs.max())
    y0, x0 = min(y0, shape[0] - 1), min(x0, shape[1] - 1)
    return (y0, max(y1, y0 + 1)), (x0, max(x1, x0 + 1))


def hog_block(crop: np.ndarray, points: np.ndarray, config: FeatureConfig) -> np.ndarray:
    """HOG of a patch around each of ``config.hog_points`` (:func:`hog_pair`'s first);
    (P * cells^2 * bins,)."""
    centres = np.round(points[list(config.hog_points)]).astype(np.int64)
    ys, xs = _corners(centres[:, 0], centres[:, 1], config, crop.shape)
    rows, cols = _window(ys, xs, crop.shape)
    integral = _window_integral(crop, config.hog_bins, rows, cols)
    sums = _cell_sums(integral, ys - rows[0], xs - cols[0])
    return _hys(sums[..., :config.hog_bins].copy(), sums).ravel()


def patch_symmetry(own: np.ndarray, mirrored: np.ndarray, n_patches: int) -> float:
    """Mean over the patches of the dot product of a (unit) patch vector and its mirror's."""
    return float(np.mean(np.sum(own.reshape(n_patches, -1) * mirrored.reshape(n_patches, -1),
                                axis=1)))


def mirror_symmetry(crop: np.ndarray, points: np.ndarray, config: FeatureConfig) -> float:
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

    Returns
    -------
    float
        In [0, 1].
    """
    return patch_symmetry(*hog_pair(crop, points, config), len(config.hog_points))
