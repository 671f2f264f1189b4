"""Fit-quality metrics (thesis section 7.3, eqs 7.4-7.7) and error statistics.

Pure functions on (N, 2) landmark arrays: ``fit`` is the converged shape and
``gt`` the ground-truth annotation, both in pixels. Errors of a set of fits
(one float per image) are summarised by :func:`ced` (cumulative error
distribution) and :func:`summarise`. A missing fit (no face found) is entered
as NaN: it counts as a failure at every threshold.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

from aamcore.io.landmarks import LandmarkScheme, as_points
from aamcore.model.similarity import Similarity

FAILURE_THRESHOLDS: tuple[float, float] = (0.08, 0.10)
"""NME above which a fit counts as a failure, as commonly reported."""


def _pair(fit: np.ndarray, gt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a, b = as_points(fit, "fit"), as_points(gt, "gt")
    if a.shape != b.shape:
        raise ValueError(f"fit {a.shape} and ground truth {b.shape} differ in shape")
    return a, b


def point_errors(fit: np.ndarray, gt: np.ndarray) -> np.ndarray:
    """Euclidean distance of each fitted point to its ground truth, shape (N,)."""
    a, b = _pair(fit, gt)
    return np.linalg.norm(a - b, axis=1)


def point_to_point(fit: np.ndarray, gt: np.ndarray) -> float:
    """Mean point-to-point distance (eq 7.4), in the units of the points."""
    return float(np.mean(point_errors(fit, gt)))


def _edge_array(edges: LandmarkScheme | Sequence[tuple[int, int]], n_points: int) -> np.ndarray:
    pairs = edges.edges if isinstance(edges, LandmarkScheme) else edges
    arr = np.asarray(list(pairs), dtype=np.int64).reshape(-1, 2)
    if len(arr) and (arr.min() < 0 or arr.max() >= n_points):
        raise ValueError(f"an edge index is outside 0..{n_points - 1}")
    return arr[arr[:, 0] != arr[:, 1]]


def _contour_labels(edges: np.ndarray, n_points: int) -> np.ndarray:
    """Connected contour of each point (-1 for a point on no edge), shape (N,)."""
    parent = np.arange(n_points)

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = int(parent[i])
        return i

    for a, b in edges:
        parent[root(int(a))] = root(int(b))
    labels = np.array([root(i) for i in range(n_points)])
    on_edge = np.zeros(n_points, dtype=bool)
    on_edge[edges.ravel()] = True
    labels[~on_edge] = -1
    return labels


def point_to_border_errors(
    fit: np.ndarray, gt: np.ndarray, edges: LandmarkScheme | Sequence[tuple[int, int]]
) -> np.ndarray:
    """Distance of each fitted point to the ground-truth contour, shape (N,).

    The contour of point ``i`` is the polyline through the ground-truth points
    of the scheme's edges that are connected to ``i`` (its own eye, lip, jaw
    line...). The distance is to the nearest point of that polyline; where the
    nearest point lies inside a segment it is measured along that segment's
    normal, so sliding a point along its contour costs nothing. Points on no
    edge fall back to the point-to-point distance.

    Parameters
    ----------
    fit, gt : (N, 2) arrays
    edges : LandmarkScheme or sequence of (int, int)
        Contour connectivity, e.g. ``scheme.edges``.
    """
    a, b = _pair(fit, gt)
    n = len(a)
    seg = _edge_array(edges, n)
    errors = np.linalg.norm(a - b, axis=1)
    if len(seg) == 0:
        return errors
    labels = _contour_labels(seg, n)
    start, end = b[seg[:, 0]], b[seg[:, 1]]  # (M, 2)
    direction = end - start
    length2 = np.sum(direction**2, axis=1)
    rel = a[:, None, :] - start[None, :, :]  # (N, M, 2)
    t = np.divide(
        np.sum(rel * direction[None], axis=2),
        length2[None],
        out=np.zeros((n, len(seg))),
        where=length2[None] > 0,
    )
    nearest = start[None] + np.clip(t, 0.0, 1.0)[..., None] * direction[None]
    dist = np.linalg.norm(a[:, None, :] - nearest, axis=2)
    own = labels[:, None] == labels[seg[:, 0]][None, :]
    dist = np.where(own, dist, np.inf)
    on_contour = labels >= 0
    errors[on_contour] = dist[on_contour].min(axis=1)
    return errors


def point_to_border(
    fit: np.ndarray, gt: np.ndarray, edges: LandmarkScheme | Sequence[tuple[int, int]]
) -> float:
    """Mean point-to-border distance (eq 7.5); see :func:`point_to_border_errors`."""
    return float(np.mean(point_to_border_errors(fit, gt, edges)))


def procrustes_align(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Align ``source`` onto ``target`` by a least-squares similarity (no reflection).

    Parameters
    ----------
    source, target : (N, 2) arrays

    Returns
    -------
    (N, 2) array
        ``source`` after the scale, rotation and translation.

    Raises
    ------
    ValueError
        If ``source`` has all its points at one place.
    """
    src, tgt = _pair(source, target)
    return Similarity.from_estimate(src, tgt).apply(src)


def procrustes_distance(fit: np.ndarray, gt: np.ndarray) -> float:
    """Average Procrustes distance (eq 7.6).

    The mean point-to-point distance after aligning ``fit`` to ``gt`` by a
    similarity transform: the shape error left once pose is discounted.
    """
    return point_to_point(procrustes_align(fit, gt), gt)


def texture_error(g_image: np.ndarray, g_model: np.ndarray) -> float:
    """Mean squared texture difference (eq 7.7), ``(1/m) sum (g_image - g_model)^2``.

    Parameters
    ----------
    g_image, g_model : (m,) arrays
        Texture sampled from the image and the model's texture.
    """
    a = np.asarray(g_image, dtype=np.float64).ravel()
    b = np.asarray(g_model, dtype=np.float64).ravel()
    if a.shape != b.shape or a.size == 0:
        raise ValueError(f"texture vectors must be non-empty and equal in size: {a.size}, {b.size}")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError("texture vectors hold NaN or infinite values")
    return float(np.mean((a - b) ** 2))


def nme(fit: np.ndarray, gt: np.ndarray, scheme: LandmarkScheme) -> float:
    """Point-to-point error over the ground truth's outer-eye-corner distance.

    Raises
    ------
    ValueError
        If the point count differs from the scheme's or the eye corners coincide.
    """
    a, b = _pair(fit, gt)
    if len(b) != scheme.n_points:
        raise ValueError(f"scheme {scheme.name} has {scheme.n_points} points, shapes have {len(b)}")
    iod = scheme.inter_ocular(b)
    if iod <= 0.0:
        raise ValueError("ground-truth outer eye corners coincide: NME undefined")
    return point_to_point(a, b) / iod


def part_nmes(fit: np.ndarray, gt: np.ndarray, scheme: LandmarkScheme) -> dict[str, float]:
    """Per named group of the scheme (``jaw``, ``mouth``, ...), the group's mean point
    error over the ground truth's outer-eye-corner distance.

    Parameters
    ----------
    fit, gt : (N, 2) arrays

    Raises
    ------
    ValueError
        As :func:`nme`.
    """
    nme(fit, gt, scheme)  # the same checks
    a, b = _pair(fit, gt)
    errors = point_errors(a, b) / scheme.inter_ocular(b)
    return {name: float(errors[list(index)].mean()) for name, index in scheme.groups.items()}


def _errors(errors: Sequence[float] | np.ndarray) -> np.ndarray:
    arr = np.asarray(errors, dtype=np.float64).ravel()
    if np.any(arr[np.isfinite(arr)] < 0):
        raise ValueError("errors must be >= 0 (NaN marks a missing fit)")
    return arr


def failure_flags(errors: Sequence[float] | np.ndarray, threshold: float) -> np.ndarray:
    """Which errors exceed ``threshold`` (NaN counts as a failure); bool (M,)."""
    arr = _errors(errors)
    return ~(arr <= threshold)


def failure_rate(errors: Sequence[float] | np.ndarray, threshold: float) -> float:
    """Fraction of errors above ``threshold`` (NaN counts as a failure)."""
    flags = failure_flags(errors, threshold)
    if len(flags) == 0:
        raise ValueError("no errors given")
    return float(np.mean(flags))


def ced(
    errors: Sequence[float] | np.ndarray, thresholds: Sequence[float] | np.ndarray
) -> np.ndarray:
    """Cumulative error distribution: fraction of errors ``<=`` each threshold.

    Parameters
    ----------
    errors : (M,) array
        One error per image; NaN for a missing fit.
    thresholds : (T,) array

    Returns
    -------
    (T,) float64 array in [0, 1], non-decreasing where ``thresholds`` is.
    """
    arr = _errors(errors)
    if len(arr) == 0:
        raise ValueError("no errors given")
    ordered = np.sort(arr[np.isfinite(arr)])
    counts = np.searchsorted(ordered, np.asarray(thresholds, dtype=np.float64), side="right")
    return counts / len(arr)


@dataclass(frozen=True)
class ErrorSummary:
    """Statistics of a set of errors; NaN entries are missing fits.

    ``mean``, ``median`` and ``std`` are over the finite errors; the failure
    rates count missing fits as failures.
    """

    n: int
    n_missing: int
    mean: float
    median: float
    std: float
    failure_008: float
    failure_010: float

    def to_dict(self) -> dict[str, float | int]:
        """Plain numbers, e.g. for JSON."""
        return asdict(self)


def summarise(errors: Sequence[float] | np.ndarray) -> ErrorSummary:
    """Mean, median, std and failure rates (> 0.08, > 0.10) of (M,) errors."""
    arr = _errors(errors)
    if len(arr) == 0:
        raise ValueError("no errors given")
    finite = arr[np.isfinite(arr)]
    nan = float("nan")
    return ErrorSummary(
        n=len(arr),
        n_missing=int(len(arr) - len(finite)),
        mean=float(finite.mean()) if len(finite) else nan,
        median=float(np.median(finite)) if len(finite) else nan,
        std=float(finite.std()) if len(finite) else nan,
        failure_008=failure_rate(arr, FAILURE_THRESHOLDS[0]),
        failure_010=failure_rate(arr, FAILURE_THRESHOLDS[1]),
    )
