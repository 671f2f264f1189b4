"""Mapping feature vectors onto the unit hypersphere (thesis section 10.2).

Each feature is centred and scaled with the mean and standard deviation of
the training data, then each vector is divided by its norm. Only the
training fold fixes the mean and scale.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted, validate_data

_TINY = 1e-12


def to_unit_sphere(X: np.ndarray, mean: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Standardise the rows of X (n, d) and normalise each to unit norm, shape (n, d).

    A row that standardises to zero stays zero (it has no direction).
    """
    Z = (X - mean) / scale
    norms = np.linalg.norm(Z, axis=1, keepdims=True)
    return Z / np.maximum(norms, _TINY)


class HypersphereMap(TransformerMixin, BaseEstimator):
    """Centre and scale per feature (fitted on training data), then unit-normalise each row."""

    def fit(self, X: np.ndarray, y: np.ndarray | None = None) -> HypersphereMap:
        """Learn the per-feature mean and standard deviation of X (n, d)."""
        X = validate_data(self, X, dtype=np.float64)
        self.mean_ = X.mean(axis=0)
        scale = X.std(axis=0)
        self.scale_ = np.where(scale > _TINY, scale, 1.0)
        return self

    def transform(self, X: np.ndarray) -> np.ndarray:
        """Unit-norm rows, shape (n, d)."""
        check_is_fitted(self, "mean_")
        X = validate_data(self, X, reset=False, dtype=np.float64)
        return to_unit_sphere(X, self.mean_, self.scale_)
