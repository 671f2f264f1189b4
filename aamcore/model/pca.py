"""Principal component analysis keeping a fraction of the variance (eqs. 3.11-3.16).

When the data has more dimensions than samples the eigenproblem is solved on
the small ``S x S`` Gram matrix (the low-memory PCA of thesis section 4.4.1).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PCA:
    """A linear subspace model ``x = mean + components @ b``.

    Attributes
    ----------
    mean : (D,) array
    components : (D, k) array
        Orthonormal columns, in decreasing order of variance.
    variances : (k,) array
        Eigenvalues kept, the variance of each parameter.
    total_variance : float
        Sum of all eigenvalues, kept or not.
    """

    mean: np.ndarray
    components: np.ndarray
    variances: np.ndarray
    total_variance: float

    @property
    def n_modes(self) -> int:
        return self.components.shape[1]

    @property
    def variance_kept(self) -> float:
        """Fraction of the total variance the kept modes explain."""
        return float(self.variances.sum() / self.total_variance) if self.total_variance else 1.0

    def project(self, x: np.ndarray) -> np.ndarray:
        """Parameters ``b`` of ``x`` (D,) or (S, D) (eq. 3.14)."""
        return (x - self.mean) @ self.components

    def reconstruct(self, b: np.ndarray) -> np.ndarray:
        """Data vector(s) for parameters ``b`` (k,) or (S, k) (eq. 3.13)."""
        return self.mean + b @ self.components.T

    def limits(self, n_sigma: float = 3.0) -> np.ndarray:
        """Parameter limits ``n_sigma * sqrt(lambda)``, shape (k,)."""
        return n_sigma * np.sqrt(self.variances)

    def truncated(self, n_modes: int) -> PCA:
        """The same model keeping only the first ``n_modes`` modes."""
        return PCA(
            self.mean, self.components[:, :n_modes], self.variances[:n_modes], self.total_variance
        )


def modes_for_variance(eigenvalues: np.ndarray, fraction: float) -> int:
    """Smallest ``t`` with ``sum(lambda[:t]) >= fraction * sum(lambda)`` (eq. 3.16)."""
    if not 0 < fraction <= 1:
        raise ValueError(f"variance fraction {fraction} not in (0, 1]")
    total = float(eigenvalues.sum())
    if total <= 0:
        return 0
    cumulative = np.cumsum(eigenvalues) / total
    return int(min(np.searchsorted(cumulative, fraction - 1e-12) + 1, len(eigenvalues)))


def fit_pca(data: np.ndarray, variance: float = 0.95, max_modes: int | None = None) -> PCA:
    """Fit a PCA keeping ``variance`` of the total variance.

    Parameters
    ----------
    data : (S, D) array
        One sample per row.
    variance : float
        Fraction of the variance to keep, in (0, 1].
    max_modes : int, optional
        Upper bound on the number of modes.

    Raises
    ------
    ValueError
        If there are fewer than two samples.
    """
    data = np.asarray(data, dtype=np.float64)
    n_samples, dim = data.shape
    if n_samples < 2:
        raise ValueError(f"PCA needs at least 2 samples, got {n_samples}")
    mean = data.mean(axis=0)
    centred = data - mean
    if dim > n_samples:
        gram = centred @ centred.T / (n_samples - 1)
        eigenvalues, small = np.linalg.eigh(gram)
        order = np.argsort(eigenvalues)[::-1]
        eigenvalues = np.clip(eigenvalues[order], 0, None)
        vectors = centred.T @ small[:, order]
        norms = np.linalg.norm(vectors, axis=0)
        valid = norms > 1e-12 * max(norms.max(), 1e-300)
        vectors = vectors[:, valid] / norms[valid]
        eigenvalues = eigenvalues[valid]
    else:
        cov = centred.T @ centred / (n_samples - 1)
        eigenvalues, vectors = np.linalg.eigh(cov)
        order = np.argsort(eigenvalues)[::-1]
        eigenvalues, vectors = np.clip(eigenvalues[order], 0, None), vectors[:, order]
    # At most S - 1 modes carry variance.
    eigenvalues, vectors = eigenvalues[: n_samples - 1], vectors[:, : n_samples - 1]
    total = float(eigenvalues.sum())
    k = modes_for_variance(eigenvalues, variance)
    if max_modes is not None:
        k = min(k, max_modes)
    k = max(k, 1)
    return PCA(mean, vectors[:, :k].copy(), eigenvalues[:k].copy(), total)
