"""Scores as probabilities: a softmax whose temperature is fitted on held-out posers.

A classifier's scores (LDA discriminants, negated Mahalanobis distances) are
unbounded; ``softmax(scores / T)`` turns them into probabilities that sum to
one, and the temperature ``T`` is chosen to minimise the negative
log-likelihood of the true class on faces of posers the classifier did not
see (:func:`held_out_scores`), so that a face called 0.8 likely is right about
80% of the time (:func:`reliability` checks it).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

CALIBRATION_FOLDS = 10
"""Folds of held-out posers the temperature is fitted on: one poser each for JAFFE's ten
(with five folds of two the scores came from classifiers of 8 posers, not 9; the stream
bench measured a 6.5-point gap between mean probability and accuracy with five folds, 4.9
with ten)."""
LOG_T_RANGE = (-6.0, 6.0)
"""Bounds of ``log T``: any calibrated temperature lies far inside."""


def softmax(scores: np.ndarray, temperature: float = 1.0) -> np.ndarray:
    """Probabilities (..., C) of scores (..., C): ``exp(s / T)`` normalised over the last axis."""
    z = np.asarray(scores, np.float64) / float(temperature)
    z = z - z.max(axis=-1, keepdims=True)
    e = np.exp(z)
    return e / e.sum(axis=-1, keepdims=True)


def fit_temperature(scores: np.ndarray, truth: np.ndarray) -> float:
    """The temperature that minimises the mean negative log-likelihood of ``truth``.

    Parameters
    ----------
    scores : (n, C) array
        Scores of faces the classifier did not learn from.
    truth : (n,) int array
        Column of each face's true class.
    """
    from scipy.optimize import minimize_scalar  # training only: serving never imports it

    scores = np.asarray(scores, np.float64)
    truth = np.asarray(truth, int)
    if scores.ndim != 2 or len(scores) != len(truth) or not len(truth):
        raise ValueError(f"scores {scores.shape} and truth {truth.shape} do not match")

    def nll(log_t: float) -> float:
        z = scores / np.exp(log_t)
        z = z - z.max(axis=1, keepdims=True)
        log_p = z - np.log(np.exp(z).sum(axis=1, keepdims=True))
        return float(-log_p[np.arange(len(truth)), truth].mean())

    found = minimize_scalar(nll, bounds=LOG_T_RANGE, method="bounded")
    return float(np.exp(found.x))


def held_out_scores(fit: Callable[[np.ndarray, np.ndarray, np.ndarray],
                                  Callable[[np.ndarray], np.ndarray]],
                    X: np.ndarray, y: np.ndarray, groups: np.ndarray,
                    folds: int = CALIBRATION_FOLDS) -> np.ndarray:
    """Every row's scores (n, C) by a classifier trained without its group (poser).

    The groups are dealt round-robin into at most ``folds`` folds, each scored by a
    classifier trained on the others (JAFFE's 10 posers: one each).
    ``fit(X, y, groups)`` returns a function of rows giving scores in the column order of
    ``np.unique(y)`` of its training rows.
    """
    groups = np.asarray(groups).astype(str)
    names = np.unique(groups)
    fold_of = {g: k % max(1, min(folds, len(names))) for k, g in enumerate(names)}
    fold = np.array([fold_of[g] for g in groups])
    out: np.ndarray | None = None
    for k in np.unique(fold):
        test = fold == k
        scores = fit(X[~test], y[~test], groups[~test])(X[test])
        if out is None:
            out = np.zeros((len(X), scores.shape[1]))
        out[test] = scores
    if out is None:
        raise ValueError("no rows to score")
    return out


def reliability(confidence: np.ndarray, correct: np.ndarray,
                edges: tuple[float, ...] = (0.0, 0.4, 0.6, 0.8, 0.9, 1.0)
                ) -> list[tuple[str, int, float, float]]:
    """A reliability diagram: per bin of the chosen label's probability, the faces in it,
    their mean probability and the share right.

    Returns
    -------
    list of (bin, count, mean probability, accuracy)
        Bins without faces are left out.
    """
    confidence = np.asarray(confidence, np.float64)
    correct = np.asarray(correct, bool)
    rows = []
    for lo, hi in zip(edges, edges[1:], strict=False):
        inside = (confidence >= lo) & ((confidence < hi) | (hi == edges[-1]))
        if inside.any():
            rows.append((f"{lo:.1f}-{hi:.1f}", int(inside.sum()),
                         float(confidence[inside].mean()), float(correct[inside].mean())))
    return rows


BIAS_GRID = np.linspace(-3.0, 3.0, 61)
"""The offsets :func:`class_biases` tries for each class, in units of the calibrated
log-probability."""


def decision_score(predicted: np.ndarray, truth: np.ndarray, n_classes: int,
                   groups: np.ndarray | None = None) -> float:
    """What :func:`class_biases` maximises: the mean of the classes' recall (a class without
    a face left out) and the share right, each half, of predicted (n,) against truth (n,);
    with ``groups`` (n,), the mean of each group's."""
    if groups is not None:
        return float(np.mean([decision_score(predicted[groups == g], truth[groups == g],
                                             n_classes) for g in np.unique(groups)]))
    recalls = [np.mean(predicted[truth == c] == c) for c in range(n_classes)
               if np.any(truth == c)]
    return 0.5 * float(np.mean(recalls)) + 0.5 * float(np.mean(predicted == truth))


def class_biases(log_p: np.ndarray, truth: np.ndarray, groups: np.ndarray | None = None,
                 rounds: int = 3) -> np.ndarray:
    """Per-class offsets (C,) to add to calibrated log-probabilities (n, C) of faces the
    model did not learn from, so that the class of highest sum is right as often as it can
    be (:func:`decision_score`, over ``groups`` (n,) when given: the expression sets, each
    as much as the others): each class's offset in turn set to the best of
    :data:`BIAS_GRID`, ``rounds`` times over; zero mean.

    A class the faces rarely show wins back what a balanced training gave the frequent
    ones, and the reverse: a label is given where it would be right.
    """
    log_p = np.asarray(log_p, np.float64)
    truth = np.asarray(truth, int)
    groups = None if groups is None else np.asarray(groups).astype(str)
    n_classes = log_p.shape[1]
    offsets = np.zeros(n_classes)
    best = decision_score(log_p.argmax(axis=1), truth, n_classes, groups)
    for _ in range(rounds):
        moved = False
        for c in range(n_classes):
            for value in BIAS_GRID:
                trial = offsets.copy()
                trial[c] = value
                score = decision_score((log_p + trial).argmax(axis=1), truth, n_classes,
                                       groups)
                if score > best + 1e-12:
                    best, offsets, moved = score, trial, True
        if not moved:
            break
    return offsets - offsets.mean()
