"""Alignment of corresponding point sets in 2 or 3 dimensions: scale, rotation and
translation by Umeyama's least squares (the 2D image placements of shapes are
:class:`aamcore.model.similarity.Similarity`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class PointAlignment:
    """``x -> scale * R @ x + t`` in 2 or 3 dimensions.

    Attributes
    ----------
    scale : float
    R : (d, d) array
        A rotation (determinant +1).
    t : (d,) array
    """

    scale: float
    R: np.ndarray
    t: np.ndarray

    def apply(self, points: np.ndarray) -> np.ndarray:
        """Transform points of shape (N, d)."""
        return self.scale * np.asarray(points) @ self.R.T + self.t


def align_points(
    src: np.ndarray, dst: np.ndarray, with_scale: bool = True
) -> PointAlignment:
    """The alignment that best maps ``src`` onto ``dst`` in the least-squares sense.

    Parameters
    ----------
    src, dst : (N, d) arrays
        Corresponding points, d = 2 or 3, N >= d.
    with_scale : bool
        Estimate the scale (else it is 1: a rigid transform).

    Raises
    ------
    ValueError
        For mismatched shapes or a degenerate source (all points equal).
    """
    src = np.asarray(src, dtype=np.float64)
    dst = np.asarray(dst, dtype=np.float64)
    if src.shape != dst.shape or src.ndim != 2 or src.shape[0] < src.shape[1]:
        raise ValueError(f"need two (N, d) arrays of equal shape with N >= d, got "
                         f"{src.shape} and {dst.shape}")
    mu_s, mu_d = src.mean(axis=0), dst.mean(axis=0)
    a, b = src - mu_s, dst - mu_d
    var_s = float(np.sum(a * a)) / len(src)
    if var_s == 0.0:
        raise ValueError("source points are all equal")
    cov = b.T @ a / len(src)
    u, sv, vt = np.linalg.svd(cov)
    d = np.ones(len(sv))
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        d[-1] = -1.0
    R = u @ np.diag(d) @ vt
    scale = float(sv @ d) / var_s if with_scale else 1.0
    return PointAlignment(scale, R, mu_d - scale * R @ mu_s)
