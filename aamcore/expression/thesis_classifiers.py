"""The thesis's classifiers as named ways to fit them (thesis 9.2 and 10.2).

:class:`ClassifierSpec` fits one on a training fold: LDA + Mahalanobis with the
Fisher directions chosen by eq 9.8, RBF SVMs with C and gamma chosen by a
cross-validation split by poser; each chooses its hyper-parameters inside the
training data. The ``thesis`` profile's classifier is the first
(:func:`aamcore.expression.training.train_thesis`); the benchmark scores all four
(:mod:`aamcore.evaluation.expression_lopo`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from aamcore.expression.concentration import choose_n_components
from aamcore.expression.lda import FisherMahalanobis
from aamcore.expression.svm import C_GRID, GAMMA_GRID, tune_svm


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
