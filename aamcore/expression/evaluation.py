"""Leave-one-poser-out results and the thesis's classifiers (thesis 9.2 and 10.2).

With few posers, a fair estimate of recognition on unseen people tests each
poser with everything fitted on the other posers only
(:func:`aamcore.expression.benchmark.evaluate_variant` runs the folds). This
module holds what the folds produce, :class:`EvaluationResult` (over every
face of the class set: a face the pipeline refused is predicted
:data:`NOT_CLASSIFIED` and counted wrong), and the thesis's classifiers as
:class:`ClassifierSpec` (LDA + Mahalanobis with the Fisher directions chosen by
eq 9.8, RBF SVMs with C and gamma chosen by a cross-validation split by
poser), which choose their hyper-parameters inside the training data.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from sklearn.metrics import confusion_matrix

from aamcore.expression.concentration import choose_n_components
from aamcore.expression.lda import FisherMahalanobis
from aamcore.expression.svm import C_GRID, GAMMA_GRID, tune_svm

NOT_CLASSIFIED = "--"
"""The prediction of a face the pipeline refused (no face, the quality gate): always wrong."""


@dataclass(frozen=True)
class ClassifierSpec:
    """A named way to fit a classifier on one training fold.

    Attributes
    ----------
    name : str
        Shown in tables (``LDA+Mahalanobis``, ``SVM DAG``).
    fit : callable
        ``fit(X (n, d), y (n,), groups (n,))`` returning a fitted estimator
        with ``predict`` and ``get_params``.
    """

    name: str
    fit: Callable[[np.ndarray, np.ndarray, np.ndarray], Any]


def lda_mahalanobis_spec(n_trials: int = 25) -> ClassifierSpec:
    """LDA + Mahalanobis with the number of Fisher directions chosen by eq 9.8 on the fold."""

    def fit(X: np.ndarray, y: np.ndarray, groups: np.ndarray) -> FisherMahalanobis:
        k = choose_n_components(X, y, n_trials=n_trials)
        return FisherMahalanobis(n_components=k).fit(X, y)

    return ClassifierSpec("LDA+Mahalanobis", fit)


def svm_spec(
    scheme: str,
    C_grid: np.ndarray = C_GRID,
    gamma_grid: np.ndarray = GAMMA_GRID,
    inner_splits: int = 3,
) -> ClassifierSpec:
    """RBF SVM with the given multi-class scheme, C and gamma tuned on the fold."""
    label = {"ova": "OvA", "ovo": "OvO", "dag": "DAG"}[scheme]

    def fit(X: np.ndarray, y: np.ndarray, groups: np.ndarray) -> Any:
        return tune_svm(X, y, groups, scheme, C_grid, gamma_grid, inner_splits)

    return ClassifierSpec(f"SVM {label}", fit)


def default_classifiers(
    n_trials: int = 25, C_grid: np.ndarray = C_GRID, gamma_grid: np.ndarray = GAMMA_GRID
) -> list[ClassifierSpec]:
    """LDA+Mahalanobis and the three SVM schemes (``ova``, ``ovo``, ``dag``)."""
    svms = [svm_spec(scheme, C_grid, gamma_grid) for scheme in ("ova", "ovo", "dag")]
    return [lda_mahalanobis_spec(n_trials), *svms]


@dataclass
class EvaluationResult:
    """Leave-one-poser-out predictions of one pipeline over every face of a class set.

    Attributes
    ----------
    classifier : str
        Name of the row (pipeline variant or classifier).
    features : str
        What was classified.
    class_names : tuple of str
        Row order of the confusion matrix.
    y_true, y_pred, test_poser : (n,) str arrays
        True and predicted class and poser of every face; ``y_pred`` is
        :data:`NOT_CLASSIFIED` for a face the pipeline refused.
    fold_params : dict
        Per test poser: the classifier's chosen parameters.
    refused : list of str
        ``"file: reason"`` of each refused face.
    """

    classifier: str
    features: str
    class_names: tuple[str, ...]
    y_true: np.ndarray
    y_pred: np.ndarray
    test_poser: np.ndarray
    fold_params: dict[str, dict[str, Any]] = field(default_factory=dict)
    refused: list[str] = field(default_factory=list)

    @property
    def columns(self) -> tuple[str, ...]:
        """The confusion matrix's columns: the classes, then :data:`NOT_CLASSIFIED` when a
        face was refused."""
        refused = bool(np.any(self.y_pred == NOT_CLASSIFIED))
        return (*self.class_names, NOT_CLASSIFIED) if refused else self.class_names

    def confusion(self) -> np.ndarray:
        """Counts, rows true class, columns :attr:`columns`, shape (n_classes, n_columns)."""
        counts = confusion_matrix(self.y_true, self.y_pred, labels=list(self.columns))
        return counts[: len(self.class_names)]

    def confusion_percent(self) -> np.ndarray:
        """Each row as percentages of its true class (tables 9.3-10.11), (n_classes, n_columns)."""
        counts = self.confusion().astype(np.float64)
        totals = counts.sum(axis=1, keepdims=True)
        return 100.0 * counts / np.maximum(totals, 1.0)

    @property
    def n(self) -> int:
        """Faces of the class set."""
        return int(len(self.y_true))

    @property
    def overall_rate(self) -> float:
        """Fraction of all faces classified correctly (refused ones count wrong)."""
        return float(np.mean(self.y_true == self.y_pred)) if self.n else float("nan")

    def per_class_rates(self) -> np.ndarray:
        """Fraction of each class classified correctly, shape (n_classes,)."""
        return np.diag(self.confusion_percent()[:, : len(self.class_names)]) / 100.0

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable summary."""
        return {
            "classifier": self.classifier,
            "features": self.features,
            "class_names": list(self.class_names),
            "columns": list(self.columns),
            "n_samples": self.n,
            "overall_rate": self.overall_rate,
            "per_class_rates": dict(
                zip(self.class_names, self.per_class_rates().tolist(), strict=True)
            ),
            "confusion_counts": self.confusion().tolist(),
            "refused": list(self.refused),
            "fold_params": self.fold_params,
        }
