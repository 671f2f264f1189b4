"""Leave-one-poser-out evaluation of expression classifiers (thesis 9.2 and 10.2).

With few posers, a fair estimate of recognition on unseen people tests each
poser with everything fitted on the other posers only. Per fold:

1. the feature extractor is fitted on the training inputs
   (:class:`FoldFeatures`: the pixel PCA baseline now, the AAM fitted
   appearance vector ``c`` later) and maps training and test inputs;
2. each classifier fits on the training features, choosing its own
   hyper-parameters inside the training data (number of Fisher directions by
   eq 9.8, SVM ``C`` and ``gamma`` by a cross-validation split by poser);
3. the test poser's samples are predicted.

The predictions of all folds form one confusion matrix per classifier.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from sklearn.metrics import confusion_matrix
from threadpoolctl import threadpool_limits

from aamcore.expression.concentration import choose_n_components
from aamcore.expression.lda import FisherMahalanobis
from aamcore.expression.svm import C_GRID, GAMMA_GRID, tune_svm

Inputs = np.ndarray | Sequence[Any]
"""Per-sample inputs of a feature extractor: an array (n, ...) or a sequence of n items."""


class FoldFeatures(Protocol):
    """A feature extractor fitted anew in every fold.

    ``name`` labels the outputs; ``fit`` sees only the training inputs and
    returns the map from inputs (a subset of the same kind) to features (m, d).
    """

    name: str

    def fit(self, train_inputs: Inputs) -> Callable[[Inputs], np.ndarray]: ...


class GivenFeatures:
    """Inputs that already are a feature matrix (n, d), used as they are."""

    name = "given features"

    def fit(self, train_inputs: Inputs) -> Callable[[Inputs], np.ndarray]:
        """Return the identity map (to float64)."""
        return lambda inputs: np.asarray(inputs, dtype=np.float64)


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
    """Leave-one-poser-out predictions of one classifier on one feature set.

    Attributes
    ----------
    classifier, features : str
        Names of the classifier and of the feature extractor.
    class_names : tuple of str
        Row and column order of the confusion matrix.
    y_true, y_pred, test_poser : (n,) arrays
        True and predicted class and poser of every test sample.
    fold_params : dict
        Per test poser: the classifier's chosen parameters and ``n_features``.
    """

    classifier: str
    features: str
    class_names: tuple[str, ...]
    y_true: np.ndarray
    y_pred: np.ndarray
    test_poser: np.ndarray
    fold_params: dict[str, dict[str, Any]] = field(default_factory=dict)

    def confusion(self) -> np.ndarray:
        """Counts, rows true class, columns predicted, shape (n_classes, n_classes)."""
        return confusion_matrix(self.y_true, self.y_pred, labels=list(self.class_names))

    def confusion_percent(self) -> np.ndarray:
        """Each row as percentages of its true class (tables 9.3-10.11), (n_classes, n_classes)."""
        counts = self.confusion().astype(np.float64)
        totals = counts.sum(axis=1, keepdims=True)
        return 100.0 * counts / np.maximum(totals, 1.0)

    @property
    def overall_rate(self) -> float:
        """Fraction of test samples classified correctly."""
        return float(np.mean(self.y_true == self.y_pred))

    def per_class_rates(self) -> np.ndarray:
        """Fraction of each class classified correctly, shape (n_classes,)."""
        return np.diag(self.confusion_percent()) / 100.0

    def mean_n_features(self) -> float:
        """Mean feature dimension over the folds."""
        dims = [p["n_features"] for p in self.fold_params.values()]
        return float(np.mean(dims)) if dims else float("nan")

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable summary."""
        return {
            "classifier": self.classifier,
            "features": self.features,
            "class_names": list(self.class_names),
            "n_samples": int(len(self.y_true)),
            "overall_rate": self.overall_rate,
            "per_class_rates": dict(
                zip(self.class_names, self.per_class_rates().tolist(), strict=True)
            ),
            "confusion_counts": self.confusion().tolist(),
            "fold_params": self.fold_params,
        }


def take(inputs: Inputs, index: np.ndarray) -> Inputs:
    """Rows ``index`` of an array, or items ``index`` of a sequence (as a list)."""
    if isinstance(inputs, np.ndarray):
        return inputs[index]
    return [inputs[i] for i in index]


def restrict_classes(labels: np.ndarray, keep: Sequence[str]) -> np.ndarray:
    """Boolean mask (n,) of the samples whose label is in ``keep``."""
    return np.isin(np.asarray(labels), list(keep))


def _scalar_params(estimator: Any) -> dict[str, Any]:
    params = estimator.get_params() if hasattr(estimator, "get_params") else {}
    out = {}
    for key, value in params.items():
        if isinstance(value, np.generic):
            value = value.item()
        if isinstance(value, (int, float, str, bool)) or value is None:
            out[key] = value
    return out


def _check_inputs(
    inputs: Inputs, labels: np.ndarray, groups: np.ndarray, class_names: Sequence[str]
) -> None:
    if not (len(inputs) == len(labels) == len(groups)):
        raise ValueError(
            f"inputs, labels and groups differ in length: {len(inputs)}, {len(labels)}, "
            f"{len(groups)}"
        )
    unknown = sorted(set(labels.tolist()) - set(class_names))
    if unknown:
        raise ValueError(f"labels {unknown} are not among the classes {list(class_names)}")
    if len(np.unique(groups)) < 2:
        raise ValueError("leave-one-poser-out needs at least 2 posers")


def _run_folds(
    inputs: Inputs,
    labels: np.ndarray,
    groups: np.ndarray,
    features: FoldFeatures,
    classifiers: Sequence[ClassifierSpec],
    progress: Callable[[str], None] | None,
) -> tuple[dict[str, np.ndarray], dict[str, dict[str, dict[str, Any]]]]:
    """Fit and predict every fold of :func:`leave_one_poser_out`.

    Returns
    -------
    predicted : dict
        Classifier name -> predicted labels (n,), each from the fold that held its poser out.
    params : dict
        Classifier name -> poser -> the fold's scalar estimator parameters and ``n_features``.
    """
    predicted = {spec.name: np.empty(len(labels), dtype=labels.dtype) for spec in classifiers}
    params: dict[str, dict[str, dict[str, Any]]] = {spec.name: {} for spec in classifiers}
    # The problems are small: parallel BLAS threads only add overhead on them.
    with threadpool_limits(limits=1):
        for poser in np.unique(groups):
            test = np.flatnonzero(groups == poser)
            train = np.flatnonzero(groups != poser)
            transform = features.fit(take(inputs, train))
            X_train, X_test = transform(take(inputs, train)), transform(take(inputs, test))
            for spec in classifiers:
                estimator = spec.fit(X_train, labels[train], groups[train])
                predicted[spec.name][test] = estimator.predict(X_test)
                fold = _scalar_params(estimator) | {"n_features": int(X_train.shape[1])}
                params[spec.name][str(poser)] = fold
            if progress is not None:
                progress(f"{features.name}: poser {poser} done ({len(test)} test samples)")
    return predicted, params


def leave_one_poser_out(
    inputs: Inputs,
    labels: np.ndarray,
    groups: np.ndarray,
    features: FoldFeatures | None = None,
    classifiers: Sequence[ClassifierSpec] | None = None,
    class_names: Sequence[str] | None = None,
    progress: Callable[[str], None] | None = None,
) -> list[EvaluationResult]:
    """Evaluate classifiers with each poser held out in turn.

    Parameters
    ----------
    inputs : (n, ...) array or sequence of n items
        Per-sample inputs of ``features``; with the default ``features`` a
        feature matrix (n, d).
    labels : (n,) array of str
        Class of each sample.
    groups : (n,) array
        Poser of each sample.
    features : FoldFeatures, optional
        Fitted on each training fold; :class:`GivenFeatures` by default.
    classifiers : sequence of ClassifierSpec, optional
        :func:`default_classifiers` by default.
    class_names : sequence of str, optional
        Confusion-matrix order; the sorted labels by default.
    progress : callable, optional
        Called with a line of text after each fold.

    Returns
    -------
    list of EvaluationResult
        One per classifier, in the order given.
    """
    labels = np.asarray(labels).astype(str)
    groups = np.asarray(groups).astype(str)
    features = features if features is not None else GivenFeatures()
    classifiers = list(classifiers) if classifiers is not None else default_classifiers()
    names = tuple(class_names) if class_names is not None else tuple(np.unique(labels))
    _check_inputs(inputs, labels, groups, names)

    predicted, params = _run_folds(inputs, labels, groups, features, classifiers, progress)
    return [
        EvaluationResult(
            spec.name, features.name, names, labels, predicted[spec.name], groups, params[spec.name]
        )
        for spec in classifiers
    ]
