"""The stored face classifiers' numpy predictors, which serving reads without scikit-learn.

:class:`LinearModel` (logistic regression and shrinkage LDA behind the block scaler) and
:class:`FittedFaceClassifier` (a predictor with its classes) are what
:mod:`.face_classifier` trains and :mod:`.classifier_file` stores (with the network of
:mod:`.network` and the thesis's models, :func:`thesis_model`); they live here, apart from
the training, so that a process that only classifies (the expression service, the library's
tracker, every command of the CLI) does not import scikit-learn and SciPy's optimisers,
about a second of start-up.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np


class Scorer(Protocol):
    """A numpy predictor: per-class scores of raw vectors (a LinearModel, an SVMModel or a
    :class:`~aamcore.expression.network.NetworkModel`)."""

    def scores(self, X: np.ndarray) -> np.ndarray: ...


@dataclass(frozen=True, eq=False)
class LinearModel:
    """Scaled linear scores: ``((x - mean) / scale) @ coef.T + intercept``.

    Attributes
    ----------
    mean, scale : (d,) float64 arrays
    coef : (n_classes, d) float64 array
    intercept : (n_classes,) float64 array
    """

    mean: np.ndarray
    scale: np.ndarray
    coef: np.ndarray
    intercept: np.ndarray

    def __post_init__(self) -> None:
        d = self.coef.shape[1] if self.coef.ndim == 2 else -1
        if self.mean.shape != (d,) or self.scale.shape != (d,):
            raise ValueError(f"mean {self.mean.shape}, scale {self.scale.shape}, coef "
                             f"{self.coef.shape}: need (d,), (d,), (k, d)")
        if self.intercept.shape != (self.coef.shape[0],):
            raise ValueError(f"intercept {self.intercept.shape} must be ({self.coef.shape[0]},)")
        if not np.all(self.scale > 0):
            raise ValueError("scale must be > 0")

    @property
    def feature_dim(self) -> int:
        """Dimension d of the input vectors."""
        return self.coef.shape[1]

    @property
    def n_classes(self) -> int:
        return self.coef.shape[0]

    def scores(self, X: np.ndarray) -> np.ndarray:
        """Per-class scores of the rows of X (n, d), shape (n, n_classes)."""
        return ((X - self.mean) / self.scale) @ self.coef.T + self.intercept

    def shifted(self, offset: np.ndarray) -> LinearModel:
        """The same model with ``offset`` (n_classes,) added to every row's scores."""
        return LinearModel(self.mean, self.scale, self.coef,
                           self.intercept + np.asarray(offset, np.float64))

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The arrays to store, by name."""
        return {"mean": self.mean, "scale": self.scale, "coef": self.coef,
                "intercept": self.intercept}

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray]) -> LinearModel:
        """Rebuild from :meth:`to_arrays` output; KeyError or ValueError when inconsistent."""
        names = ("mean", "scale", "coef", "intercept")
        return cls(*(np.asarray(arrays[k], np.float64) for k in names))


@dataclass
class FittedFaceClassifier:
    """What :func:`fit_face_classifier` returns.

    Attributes
    ----------
    model : LinearModel, SVMModel or NetworkModel
        The numpy predictor of raw (unscaled) feature vectors.
    classes : tuple of str
        Class of each score column.
    kind : str
        ``"linear"``, ``"svm_ova"`` (kinds of the classifier file) or ``"network"`` (a
        person-independent model only).
    params : dict
        The classifier's name and chosen hyper-parameters.
    """

    model: Scorer
    classes: tuple[str, ...]
    kind: str
    params: dict[str, Any]

    def scores(self, X: np.ndarray) -> np.ndarray:
        """Per-class scores (n, n_classes) of raw feature vectors X (n, d)."""
        return self.model.scores(np.asarray(X, np.float64))

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Class of each row of X (n, d), shape (n,)."""
        return np.array(self.classes)[np.argmax(self.scores(X), axis=1)]


def thesis_model(kind: str) -> type:
    """The stored model of a thesis classifier ``kind`` (``lda_mahalanobis``:
    :class:`~aamcore.expression.lda.MahalanobisModel`, ``svm_*``:
    :class:`~aamcore.expression.svm.SVMModel`); this imports scikit-learn."""
    from aamcore.expression.lda import MahalanobisModel
    from aamcore.expression.svm import SVMModel

    return MahalanobisModel if kind == "lda_mahalanobis" else SVMModel
