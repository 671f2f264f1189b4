"""RBF support vector machine expression classifier (thesis chapter 10).

Features are mapped to the unit hypersphere (:mod:`.hypersphere`), then
binary RBF machines are trained with scikit-learn's SVC: one per class for
one-against-all, one per class pair for one-against-one and for the decision
DAG, which scikit-learn lacks and :mod:`.multiclass` builds on the pairwise
machines. ``C`` and ``gamma`` are chosen by a grid search over powers of two
with a cross-validation split by poser, inside the training data only
(:func:`tune_svm`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.model_selection import GridSearchCV, GroupKFold
from sklearn.utils.validation import check_is_fitted, validate_data

from aamcore.expression.hypersphere import HypersphereMap, to_unit_sphere
from aamcore.expression.kernel_machines import (
    REST,
    RBFMachines,
    fit_one_against_all,
    fit_pairwise,
)
from aamcore.expression.multiclass import SCHEMES, dag_scores, ovo_scores, pair_index

C_GRID: np.ndarray = 2.0 ** np.arange(-1, 14, 2)
"""Default penalties tried: 2^-1, 2^1, ..., 2^13."""
GAMMA_GRID: np.ndarray = 2.0 ** np.arange(-9, 2, 2)
"""Default RBF widths tried: 2^-9, ..., 2^1 (unit-norm vectors lie at distances 0..2)."""
SVM_GRIDS: dict[str, tuple[np.ndarray, np.ndarray]] = {
    "full": (C_GRID, GAMMA_GRID),
    "coarse": (2.0 ** np.array([1, 5, 9]), 2.0 ** np.array([-7, -3, 1])),
}
"""Named (C, gamma) grids: ``full`` (48 pairs) and ``coarse`` (9 pairs, for quick runs)."""


def _machine_sides(machines: RBFMachines) -> set[tuple[int, int]]:
    """The (class, class or REST) pairs of the machines, smaller class first."""
    sides = zip(machines.positive.tolist(), machines.negative.tolist(), strict=True)
    return {(i, j) if j == REST else (min(i, j), max(i, j)) for i, j in sides}


def _expected_sides(n_classes: int, one_against_all: bool) -> set[tuple[int, int]]:
    if one_against_all:
        return {(i, REST) for i in range(n_classes)}
    return {(i, j) for i in range(n_classes) for j in range(i + 1, n_classes)}


@dataclass(frozen=True)
class SVMModel:
    """Hypersphere mapping, binary machines and a multi-class scheme, as arrays.

    Attributes
    ----------
    mean, scale : (d,) float64 arrays
        Per-feature centring and scaling of the hypersphere mapping.
    machines : RBFMachines
        The binary machines.
    scheme : {"ova", "ovo", "dag"}
    n_classes : int
    """

    mean: np.ndarray
    scale: np.ndarray
    machines: RBFMachines
    scheme: str
    n_classes: int

    def __post_init__(self) -> None:
        if self.scheme not in SCHEMES:
            raise ValueError(f"unknown SVM scheme {self.scheme!r} (expected one of {SCHEMES})")
        ova = self.scheme == "ova"
        expected = self.n_classes if ova else self.n_classes * (self.n_classes - 1) // 2
        if self.machines.n_machines != expected:
            raise ValueError(
                f"{self.scheme} with {self.n_classes} classes needs {expected} machines, "
                f"got {self.machines.n_machines}"
            )
        sides = _machine_sides(self.machines)
        if sides != _expected_sides(self.n_classes, ova):
            raise ValueError(f"the machines' class pairs do not match {self.scheme}")
        if self.mean.shape != self.scale.shape or self.mean.shape != (self.feature_dim,):
            raise ValueError(f"mean {self.mean.shape} and scale {self.scale.shape} must be (d,)")
        if not ova:
            object.__setattr__(
                self,
                "_index",
                pair_index(self.machines.positive, self.machines.negative, self.n_classes),
            )

    @property
    def feature_dim(self) -> int:
        """Dimension d of the input vectors."""
        return self.machines.support_vectors.shape[1]

    def scores(self, X: np.ndarray) -> np.ndarray:
        """Per-class scores of the rows of X (n, d), shape (n, n_classes); argmax is the class."""
        values = self.machines.decision_values(to_unit_sphere(X, self.mean, self.scale))
        if self.scheme == "ova":
            return values
        if self.scheme == "ovo":
            m = self.machines
            return ovo_scores(values, m.positive, m.negative, self.n_classes)
        return dag_scores(values, self.machines.positive, self._index)

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The arrays to store, by name."""
        return {"mean": self.mean, "scale": self.scale, **self.machines.to_arrays()}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], scheme: str, n_classes: int) -> SVMModel:
        """Rebuild from :meth:`to_arrays` output; raises ValueError on inconsistent arrays."""
        return cls(
            mean=np.asarray(arrays["mean"], np.float64),
            scale=np.asarray(arrays["scale"], np.float64),
            machines=RBFMachines.from_arrays(arrays),
            scheme=scheme,
            n_classes=n_classes,
        )


class SVMExpressionClassifier(ClassifierMixin, BaseEstimator):
    """RBF SVM on unit-hypersphere features with a one-against-all, pairwise or DAG decision.

    Parameters
    ----------
    scheme : {"ova", "ovo", "dag"}
        One-against-all (eq 10.7), one-against-one max wins, or decision DAG.
    C : float
        Penalty of the slack variables (eq 10.3).
    gamma : float
        RBF kernel width.
    """

    def __init__(self, scheme: str = "ova", C: float = 1.0, gamma: float = 1.0) -> None:
        self.scheme = scheme
        self.C = C
        self.gamma = gamma

    def fit(self, X: np.ndarray, y: np.ndarray) -> SVMExpressionClassifier:
        """Fit on features X (n, d) with labels y (n,)."""
        if self.scheme not in SCHEMES:
            raise ValueError(f"unknown SVM scheme {self.scheme!r} (expected one of {SCHEMES})")
        X, y = validate_data(self, X, y, dtype=np.float64)
        self.classes_, y_idx = np.unique(y, return_inverse=True)
        if len(self.classes_) < 2:
            raise ValueError(f"need at least 2 classes to fit, got {len(self.classes_)}")
        sphere = HypersphereMap().fit(X)
        fit = fit_one_against_all if self.scheme == "ova" else fit_pairwise
        machines = fit(sphere.transform(X), y_idx, len(self.classes_), self.C, self.gamma)
        self.model_ = SVMModel(
            sphere.mean_, sphere.scale_, machines, self.scheme, len(self.classes_)
        )
        return self

    def decision_scores(self, X: np.ndarray) -> np.ndarray:
        """Per-class scores (n, n_classes), columns in ``classes_`` (see :mod:`.multiclass`)."""
        check_is_fitted(self, "model_")
        return self.model_.scores(validate_data(self, X, reset=False, dtype=np.float64))

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Predicted class of each row of X (n, d), shape (n,)."""
        return self.classes_[np.argmax(self.decision_scores(X), axis=1)]


def tune_svm(
    X: np.ndarray,
    y: np.ndarray,
    groups: np.ndarray,
    scheme: str,
    C_grid: np.ndarray = C_GRID,
    gamma_grid: np.ndarray = GAMMA_GRID,
    inner_splits: int = 3,
) -> SVMExpressionClassifier:
    """Choose C and gamma by grouped cross-validation, then refit on all of X.

    Parameters
    ----------
    X : (n, d) float array
        Training features.
    y : (n,) array
        Labels.
    groups : (n,) array
        Poser of each sample: no poser is on both sides of an inner split.
    scheme : {"ova", "ovo", "dag"}
    C_grid, gamma_grid : 1-D arrays
        Values tried (powers of two by default).
    inner_splits : int
        Folds of the inner :class:`~sklearn.model_selection.GroupKFold`
        (at most the number of posers).

    Returns
    -------
    SVMExpressionClassifier
        Fitted on all of X with the best parameters.
    """
    n_groups = len(np.unique(groups))
    if n_groups < 2:
        raise ValueError(f"tuning needs samples of at least 2 posers, got {n_groups}")
    search = GridSearchCV(
        SVMExpressionClassifier(scheme=scheme),
        {"C": list(C_grid), "gamma": list(gamma_grid)},
        cv=GroupKFold(n_splits=min(inner_splits, n_groups)),
        scoring="accuracy",
        refit=True,
        error_score="raise",
    )
    search.fit(X, y, groups=groups)
    return search.best_estimator_
