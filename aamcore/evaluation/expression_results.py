"""Predictions of an expression benchmark row over every face of a class set, and its scores.

:class:`EvaluationResult` holds the true and predicted class of every face (a face the
pipeline refused is predicted :data:`NOT_CLASSIFIED`) with the person it belongs to, and
gives what the benchmark reports: the share of faces labelled, the accuracy of the labelled
ones, the recall of each class and their mean (the sets are unbalanced: a classifier that
says "neutral" to everything must not look good), and the confusion matrix.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from sklearn.metrics import confusion_matrix

NOT_CLASSIFIED = "--"
"""The prediction of a face the pipeline refused (no face, the quality gate)."""


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

    @property
    def labelled(self) -> np.ndarray:
        """Faces (n,) the pipeline gave a label."""
        return self.y_pred != NOT_CLASSIFIED

    @property
    def share_labelled(self) -> float:
        """Fraction of the faces given a label."""
        return float(self.labelled.mean()) if self.n else float("nan")

    @property
    def labelled_accuracy(self) -> float:
        """Fraction of the labelled faces labelled right."""
        mask = self.labelled
        return float(np.mean(self.y_true[mask] == self.y_pred[mask])) if mask.any() \
            else float("nan")

    def recalls(self) -> dict[str, tuple[int, int]]:
        """Per class: labelled faces of the class labelled right, and labelled faces of the
        class (0 for a class without one)."""
        mask = self.labelled
        out = {}
        for name in self.class_names:
            mine = mask & (self.y_true == name)
            out[name] = (int(np.sum(self.y_pred[mine] == name)), int(mine.sum()))
        return out

    @property
    def mean_recall(self) -> float:
        """Mean of the recalls of the classes with labelled faces."""
        rates = [r / n for r, n in self.recalls().values() if n]
        return float(np.mean(rates)) if rates else float("nan")

    @property
    def missing_classes(self) -> list[str]:
        """Classes without a face here (said, not scored)."""
        return [c for c in self.class_names if not np.any(self.y_true == c)]

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
            "share_labelled": self.share_labelled,
            "labelled_accuracy": self.labelled_accuracy,
            "recalls": self.recalls(),
            "mean_recall": self.mean_recall,
            "missing_classes": self.missing_classes,
            "per_class_rates": dict(
                zip(self.class_names, self.per_class_rates().tolist(), strict=True)
            ),
            "confusion_counts": self.confusion().tolist(),
            "refused": list(self.refused),
            "fold_params": self.fold_params,
        }
