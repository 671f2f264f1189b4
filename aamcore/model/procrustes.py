"""Procrustes alignment of landmark shapes (thesis Algorithms 1 and 2).

Shapes are ``(N, 2)`` arrays of ``(x, y)`` points.
"""

from __future__ import annotations

import numpy as np

from aamcore.model.similarity import Similarity


def centre(points: np.ndarray) -> np.ndarray:
    """Translate ``points`` (N, 2) so that their centroid is the origin."""
    return points - points.mean(axis=0)


def normalise(points: np.ndarray) -> np.ndarray:
    """Centre ``points`` (N, 2) and scale them to unit Frobenius norm."""
    centred = centre(points)
    norm = np.linalg.norm(centred)
    if norm == 0 or not np.isfinite(norm):
        raise ValueError("degenerate shape: all points coincide or are not finite")
    return centred / norm


def rotation_to(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Optimal rotation aligning centred ``source`` to centred ``target`` (Algorithm 1).

    Returns the 2x2 matrix ``R`` minimising ``|source R^T - target|``, with no
    reflection.
    """
    u, _, vt = np.linalg.svd(target.T @ source)
    d = np.sign(np.linalg.det(u @ vt)) or 1.0
    return u @ np.diag([1.0, d]) @ vt


def procrustes_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Procrustes distance (eq. 3.2) between ``a`` aligned onto ``b``, both (N, 2)."""
    aligned = Similarity.from_estimate(a, b).apply(a)
    return float(np.sqrt(np.sum((aligned - b) ** 2)))


def generalised_procrustes(
    shapes: np.ndarray, tol: float = 1e-10, max_iter: int = 100
) -> tuple[np.ndarray, np.ndarray, int]:
    """Generalised Procrustes analysis (Algorithm 2).

    Parameters
    ----------
    shapes : (S, N, 2) array
        Training shapes.
    tol : float
        Convergence threshold on the change of the mean shape.
    max_iter : int
        Iteration limit.

    Returns
    -------
    aligned : (S, N, 2) array
        Shapes aligned to the mean, each centred and of unit norm.
    mean : (N, 2) array
        Mean shape, centred, of unit norm, oriented like the first shape.
    iterations : int
    """
    shapes = np.asarray(shapes, dtype=np.float64)
    if shapes.ndim != 3 or shapes.shape[2] != 2 or len(shapes) < 2:
        raise ValueError(f"expected (S >= 2, N, 2) shapes, got {shapes.shape}")
    unit = np.stack([normalise(s) for s in shapes])
    mean = unit[0].copy()
    aligned = unit
    for iteration in range(1, max_iter + 1):  # noqa: B007 (returned)
        aligned = np.stack([s @ rotation_to(s, mean).T for s in unit])
        # Renormalise the new mean and keep it oriented like the first shape,
        # so that the iteration can neither shrink nor spin it.
        new_mean = normalise(aligned.mean(axis=0))
        new_mean = new_mean @ rotation_to(new_mean, unit[0]).T
        change = float(np.linalg.norm(new_mean - mean))
        mean = new_mean
        if change < tol:
            break
    aligned = np.stack([s @ rotation_to(s, mean).T for s in unit])
    return aligned, mean, iteration
