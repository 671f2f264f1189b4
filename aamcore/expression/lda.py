"""Fisher LDA projection and Mahalanobis classification (thesis eqs 9.6 and 9.9).

scikit-learn's :class:`~sklearn.discriminant_analysis.LinearDiscriminantAnalysis`
finds the Fisher directions, the leading eigenvectors of ``S_W^-1 S_B``
(eq 9.6). In that Fisherspace each class is represented by its centroid and
all classes share the pooled within-class covariance ``Sigma``; a vector is
assigned to the class of smallest Mahalanobis distance (eq 9.9). The fitted
classifier keeps its arrays in a :class:`MahalanobisModel`, a pure numpy
predictor that can be saved without pickle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.discriminant_analysis import LinearDiscriminantAnalysis
from sklearn.utils.validation import check_is_fitted, validate_data


@dataclass(frozen=True)
class MahalanobisModel:
    """Fisherspace projection with class centroids and a pooled covariance.

    Attributes
    ----------
    offset : (d,) float64 array
        Subtracted from a feature vector before projection.
    projection : (d, k) float64 array
        Fisher directions as columns: ``z = (x - offset) @ projection``.
    centroids : (n_classes, k) float64 array
        Class means in Fisherspace.
    precision : (k, k) float64 array
        Inverse of the pooled within-class covariance in Fisherspace.
    """

    offset: np.ndarray
    projection: np.ndarray
    centroids: np.ndarray
    precision: np.ndarray

    @property
    def feature_dim(self) -> int:
        """Dimension d of the input vectors."""
        return self.projection.shape[0]

    def project(self, X: np.ndarray) -> np.ndarray:
        """Fisherspace coordinates of the rows of X (n, d), shape (n, k)."""
        return (X - self.offset) @ self.projection

    def squared_distances(self, X: np.ndarray) -> np.ndarray:
        """Squared Mahalanobis distance of each row of X (n, d) to each centroid, (n, n_classes)."""
        diff = self.project(X)[:, None, :] - self.centroids[None, :, :]
        return np.einsum("nck,kl,ncl->nc", diff, self.precision, diff)

    def scores(self, X: np.ndarray) -> np.ndarray:
        """Per-class scores, the negated squared distances, shape (n, n_classes)."""
        return -self.squared_distances(X)

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The arrays to store, by name."""
        return {
            "offset": self.offset,
            "projection": self.projection,
            "centroids": self.centroids,
            "precision": self.precision,
        }

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> MahalanobisModel:
        """Rebuild from :meth:`to_arrays` output; raises ValueError on inconsistent shapes."""
        model = cls(*(np.asarray(arrays[k], np.float64) for k in cls.array_names()))
        d, k = model.projection.shape
        if model.offset.shape != (d,) or model.centroids.shape[1:] != (k,):
            raise ValueError(
                f"inconsistent LDA arrays: offset {model.offset.shape}, projection "
                f"{model.projection.shape}, centroids {model.centroids.shape}"
            )
        if model.precision.shape != (k, k):
            raise ValueError(f"LDA precision has shape {model.precision.shape}, expected {(k, k)}")
        return model

    @staticmethod
    def array_names() -> tuple[str, ...]:
        """Names of the stored arrays, in constructor order."""
        return ("offset", "projection", "centroids", "precision")


def pooled_covariance(Z: np.ndarray, y_idx: np.ndarray, centroids: np.ndarray) -> np.ndarray:
    """Pooled within-class covariance of Z (n, k) around ``centroids[y_idx]``, shape (k, k).

    Normalised by ``n - n_classes``, the unbiased pooled estimate.
    """
    residuals = Z - centroids[y_idx]
    dof = max(len(Z) - len(centroids), 1)
    return residuals.T @ residuals / dof


def _projection_arrays(lda: LinearDiscriminantAnalysis, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Offset (d,) and projection (d, k) reproducing ``lda.transform``."""
    projection = np.asarray(lda.scalings_[:, :k], np.float64)
    if lda.solver == "svd":
        return np.asarray(lda.xbar_, np.float64), projection
    return np.zeros(projection.shape[0]), projection


class FisherMahalanobis(ClassifierMixin, BaseEstimator):
    """Fisher LDA projection followed by nearest centroid in Mahalanobis distance.

    Parameters
    ----------
    n_components : int, optional
        Number of Fisher directions kept; at most ``n_classes - 1``, all of
        them by default. :func:`aamcore.expression.concentration.choose_n_components`
        chooses it from the training data (thesis section 9.1.2).
    solver : {"svd", "eigen"}
        scikit-learn LDA solver. ``"eigen"`` solves eq 9.6 directly and needs
        a full-rank within-class scatter (more samples than dimensions, or a
        ``shrinkage``); ``"svd"`` finds the same directions within the range
        of the within-class scatter and copes with a singular one.
    shrinkage : float or "auto", optional
        Ledoit-Wolf or fixed shrinkage of the within-class covariance; only
        with ``solver="eigen"``.
    """

    def __init__(
        self,
        n_components: int | None = None,
        solver: str = "svd",
        shrinkage: float | str | None = None,
    ) -> None:
        self.n_components = n_components
        self.solver = solver
        self.shrinkage = shrinkage

    def fit(self, X: np.ndarray, y: np.ndarray) -> FisherMahalanobis:
        """Fit on features X (n, d) with labels y (n,)."""
        if self.solver not in ("svd", "eigen"):
            raise ValueError(f"solver must be 'svd' or 'eigen', not {self.solver!r}")
        X, y = validate_data(self, X, y, dtype=np.float64)
        self.classes_, y_idx = np.unique(y, return_inverse=True)
        if len(self.classes_) < 2:
            raise ValueError(f"need at least 2 classes to fit, got {len(self.classes_)}")
        lda = LinearDiscriminantAnalysis(
            solver=self.solver, n_components=self.n_components, shrinkage=self.shrinkage
        ).fit(X, y)
        k = lda.transform(X[:1]).shape[1]
        offset, projection = _projection_arrays(lda, k)
        Z = (X - offset) @ projection
        centroids = np.stack([Z[y_idx == c].mean(axis=0) for c in range(len(self.classes_))])
        covariance = pooled_covariance(Z, y_idx, centroids)
        precision = np.linalg.pinv(covariance, hermitian=True)
        self.lda_ = lda
        self.model_ = MahalanobisModel(offset, projection, centroids, precision)
        return self

    def transform(self, X: np.ndarray) -> np.ndarray:
        """Fisherspace coordinates of X (n, d), shape (n, k)."""
        return self.model_.project(self._check(X))

    def mahalanobis(self, X: np.ndarray) -> np.ndarray:
        """Squared Mahalanobis distances (eq 9.9) to every class centroid, shape (n, n_classes)."""
        return self.model_.squared_distances(self._check(X))

    def decision_scores(self, X: np.ndarray) -> np.ndarray:
        """Per-class scores (higher is closer), shape (n, n_classes), columns in ``classes_``."""
        return -self.mahalanobis(X)

    def predict_proba(self, X: np.ndarray) -> np.ndarray:
        """Posteriors of Gaussians sharing the pooled covariance, equal priors, (n, n_classes)."""
        logits = -0.5 * self.mahalanobis(X)
        logits -= logits.max(axis=1, keepdims=True)
        p = np.exp(logits)
        return p / p.sum(axis=1, keepdims=True)

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Class of smallest Mahalanobis distance for each row of X, shape (n,)."""
        return self.classes_[np.argmin(self.mahalanobis(X), axis=1)]

    def _check(self, X: np.ndarray) -> np.ndarray:
        check_is_fitted(self, "model_")
        return validate_data(self, X, reset=False, dtype=np.float64)
