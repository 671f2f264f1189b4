"""Classifiers of face-feature vectors: block weighting, scikit-learn training, numpy scoring.

A face-feature vector (:mod:`.analysis`) concatenates blocks of very
different sizes (1836 HOG values, 136 shape coordinates, the fitter's ``c``).
:class:`BlockScaler` standardises every feature on the training data and
scales each block by ``weight / sqrt(block length)``, so that each block's
weight, not its length, sets its share of a linear classifier or of a
kernel's distance.

:func:`fit_face_classifier` trains one of :data:`CLASSIFIERS` behind the
block scaler and returns a pure numpy predictor
(:class:`~aamcore.expression.scores.LinearModel`) for
multinomial logistic regression (the deployed models, scikit-learn's
``LogisticRegression`` with class and sample weights) and shrinkage LDA (solved by
:mod:`.shrinkage_lda`), :class:`~aamcore.expression.svm.SVMModel` for the RBF SVM; all are
saved without pickle by :class:`~aamcore.expression.classifier_file.ExpressionClassifier`.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted, validate_data

from aamcore.expression.scores import FittedFaceClassifier, LinearModel
from aamcore.expression.shrinkage_lda import shrinkage_lda
from aamcore.expression.svm import SVMModel, tune_svm

CLASSIFIERS: tuple[str, ...] = ("logistic", "lda", "rbf_svm")
"""``logistic``: multinomial logistic regression, classes weighted inversely to their
frequency (:func:`fit_logistic` sets C and sample weights); ``lda``: shrinkage LDA
(Ledoit-Wolf, no free parameter); ``rbf_svm``: one-against-all
RBF SVM on the hypersphere (thesis chapter 10), C and gamma chosen by a cross-validation
grouped by poser inside the training data."""
RBF_C = np.array([1.0, 8.0, 64.0])
RBF_GAMMA = np.array([0.125, 0.5, 2.0])
"""The RBF SVM's grid: block-scaled vectors are far from the thesis's, so its own."""
_TINY = 1e-12


def block_scale(
    std: np.ndarray, block_dims: Mapping[str, int], weights: Mapping[str, float]
) -> np.ndarray:
    """Per-feature divisor (d,): ``std * sqrt(block length) / block weight``.

    Parameters
    ----------
    std : (d,) array
        Per-feature standard deviation (zeros are taken as 1).
    block_dims : mapping str -> int
        Block lengths in vector order; their sum is d.
    weights : mapping str -> float
        Weight of each block (1 when missing); must be > 0.
    """
    std = np.where(np.asarray(std, np.float64) > _TINY, std, 1.0)
    if sum(block_dims.values()) != std.shape[0]:
        raise ValueError(f"blocks {dict(block_dims)} do not add up to {std.shape[0]} features")
    factors = []
    for name, dim in block_dims.items():
        weight = float(weights.get(name, 1.0))
        if not weight > 0:
            raise ValueError(f"block weight of {name!r} must be > 0, got {weight}")
        factors.append(np.full(dim, np.sqrt(dim) / weight))
    return std * np.concatenate(factors)


class BlockScaler(TransformerMixin, BaseEstimator):
    """Standardise each feature, then weight each block by ``weight / sqrt(length)``.

    Parameters
    ----------
    block_dims : tuple of (str, int)
        Block names and lengths in vector order.
    weights : tuple of (str, float)
        Block weights (1 for a block not named).
    """

    def __init__(
        self,
        block_dims: tuple[tuple[str, int], ...] = (),
        weights: tuple[tuple[str, float], ...] = (),
    ) -> None:
        self.block_dims = block_dims
        self.weights = weights

    def fit(self, X: np.ndarray, y: np.ndarray | None = None) -> BlockScaler:
        """Learn the mean (d,) and divisor (d,) from X (n, d)."""
        X = validate_data(self, X, dtype=np.float64)
        dims = dict(self.block_dims) or {"all": X.shape[1]}
        self.mean_ = X.mean(axis=0)
        self.scale_ = block_scale(X.std(axis=0), dims, dict(self.weights))
        return self

    def transform(self, X: np.ndarray) -> np.ndarray:
        """``(X - mean) / scale``, shape (n, d)."""
        check_is_fitted(self, "mean_")
        X = validate_data(self, X, reset=False, dtype=np.float64)
        return (X - self.mean_) / self.scale_


def _rbf_svm(scaler: BlockScaler, Z: np.ndarray, y: np.ndarray, groups: np.ndarray,
             inner_splits: int) -> FittedFaceClassifier:
    svm = tune_svm(Z, y, groups, "ova", RBF_C, RBF_GAMMA, inner_splits)
    inner = svm.model_
    # Fold the block scaling into the hypersphere map: ((x - m) / s - m2) / s2.
    model = SVMModel(scaler.mean_ + inner.mean * scaler.scale_, inner.scale * scaler.scale_,
                     inner.machines, inner.scheme, inner.n_classes)
    params = {"classifier": "rbf_svm", "C": float(svm.C), "gamma": float(svm.gamma)}
    return FittedFaceClassifier(model, tuple(str(c) for c in svm.classes_), "svm_ova", params)


def fit_face_classifier(
    X: np.ndarray,
    y: np.ndarray,
    groups: np.ndarray,
    block_dims: Mapping[str, int],
    weights: Mapping[str, float] | None = None,
    classifier: str = "lda",
    inner_splits: int = 3,
) -> FittedFaceClassifier:
    """Train a classifier of face-feature vectors.

    Parameters
    ----------
    X : (n, d) float array
        Feature vectors (absolute or relative to each face's reference).
    y : (n,) array of str
        Class of each vector.
    groups : (n,) array
        Poser of each vector, for the grouped inner cross-validation.
    block_dims : mapping str -> int
        Block names and lengths in vector order (sum d).
    weights : mapping str -> float, optional
        Block weights of :class:`BlockScaler` (1 by default).
    classifier : str
        One of :data:`CLASSIFIERS`.
    inner_splits : int
        Folds of the inner grouped cross-validation of the RBF SVM.

    Returns
    -------
    FittedFaceClassifier
    """
    if classifier not in CLASSIFIERS:
        raise ValueError(f"unknown classifier {classifier!r}: choose one of {CLASSIFIERS}")
    if classifier == "logistic":
        return fit_logistic(X, y, block_dims, weights)
    X = np.asarray(X, np.float64)
    y = np.asarray(y).astype(str)
    groups = np.asarray(groups).astype(str)
    scaler = BlockScaler(tuple(block_dims.items()), tuple((weights or {}).items())).fit(X)
    Z = scaler.transform(X)
    if classifier == "rbf_svm":
        return _rbf_svm(scaler, Z, y, groups, inner_splits)
    classes, coef, intercept = shrinkage_lda(Z, y)
    if len(classes) == 2:  # one score, negated for the first class, as scikit-learn's
        coef = np.vstack([coef[0] - coef[1], coef[1] - coef[0]])
        intercept = np.array([intercept[0] - intercept[1], intercept[1] - intercept[0]])
    model = LinearModel(scaler.mean_.copy(), scaler.scale_.copy(), coef, intercept)
    return FittedFaceClassifier(model, tuple(str(c) for c in classes), "linear",
                                {"classifier": "lda"})


def fit_logistic(
    X: np.ndarray,
    y: np.ndarray,
    block_dims: Mapping[str, int],
    weights: Mapping[str, float] | None = None,
    C: float = 1.0,
    sample_weight: np.ndarray | None = None,
    start: FittedFaceClassifier | None = None,
    max_iter: int = 300,
) -> FittedFaceClassifier:
    """Multinomial logistic regression of block-scaled vectors, classes weighted inversely to
    their frequency (times ``sample_weight``), as a :class:`LinearModel`.

    Parameters
    ----------
    X : (n, d) float array
    y : (n,) array of str
    block_dims, weights
        As :func:`fit_face_classifier`.
    C : float
        Inverse L2 penalty of scikit-learn's ``LogisticRegression``.
    sample_weight : (n,) float array, optional
    start : FittedFaceClassifier, optional
        A model of the same classes and blocks whose coefficients start the solver (it
        converges to the same optimum, in fewer iterations).
    max_iter : int
    """
    from sklearn.linear_model import LogisticRegression  # here: serving never imports it

    X = np.asarray(X, np.float64)
    y = np.asarray(y).astype(str)
    scaler = BlockScaler(tuple(block_dims.items()), tuple((weights or {}).items())).fit(X)
    warm = (start is not None and isinstance(start.model, LinearModel) and len(start.classes) > 2
            and start.classes == tuple(np.unique(y)) and start.model.feature_dim == X.shape[1])
    model = LogisticRegression(C=C, class_weight="balanced", max_iter=max_iter, warm_start=warm)
    if warm:
        assert start is not None and isinstance(start.model, LinearModel)
        # The start's coefficients are of its own scaling: re-expressed in this one's.
        ratio = scaler.scale_ / start.model.scale
        model.coef_ = start.model.coef * ratio
        model.intercept_ = start.model.intercept + (
            (scaler.mean_ - start.model.mean) / start.model.scale) @ start.model.coef.T
    model.fit(scaler.transform(X), y, sample_weight=sample_weight)
    coef, intercept = model.coef_, model.intercept_
    if len(model.classes_) == 2:  # one row of scores: the second class's, as +/- halves
        coef = np.vstack([-coef[0], coef[0]]) / 2.0
        intercept = np.array([-intercept[0], intercept[0]]) / 2.0
    linear = LinearModel(scaler.mean_.copy(), scaler.scale_.copy(), coef, intercept)
    return FittedFaceClassifier(linear, tuple(str(c) for c in model.classes_), "linear",
                                {"classifier": "logistic", "C": float(C)})
