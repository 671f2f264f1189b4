"""The expression models learned from labelled faces of many people (scikit-learn).

Two multinomial logistic regressions of the face-feature vectors
(:func:`~aamcore.expression.face_classifier.fit_logistic`, classes weighted inversely to
their frequency, each expression set weighted as :class:`Recipe` says):

- the **person-independent** (absolute) model of the vectors themselves: it answers a
  stream's first frames, and any frame of a stream without a reference yet;
- the **relative** model of ``vector - reference``, where a face's reference is the
  per-feature median of its person's classifiable faces: what the stream's reference (the
  running median of its classifiable frames,
  :class:`~aamcore.expression.reference.NeutralReference`) becomes over a session of that
  person. Only people with at least
  ``Recipe.min_reference_faces`` faces train it.

Once a stream's reference is ready the two are fused: ``log p_rel + w log p_abs``
(``w = Recipe.absolute_weight``) through a softmax of its own temperature. The three
temperatures are fitted on out-of-fold scores, the folds made of whole people, so that a
probability means on new people what it says.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from aamcore.expression.calibration import fit_temperature, softmax
from aamcore.expression.face_classifier import FittedFaceClassifier, fit_logistic
from aamcore.expression.reference import poser_references


@dataclass(frozen=True)
class Recipe:
    """How the models are learned.

    Attributes
    ----------
    C, relative_C : float
        Inverse L2 penalties of the absolute and relative models.
    absolute_weight : float
        Weight of the absolute model's log-probabilities in the fused score (0: the relative
        model alone once the reference is ready).
    set_weights : tuple of (str, float)
        Sample weight of each expression set's faces (1 when not named).
    min_reference_faces : int
        Faces a person needs for a reference of their own (the relative model's rows).
    folds : int
        Folds of whole people for the out-of-fold scores the temperatures are fitted on.
    """

    C: float = 1.0
    relative_C: float = 1.0
    absolute_weight: float = 0.25
    set_weights: tuple[tuple[str, float], ...] = ()
    min_reference_faces: int = 3
    folds: int = 4

    def __post_init__(self) -> None:
        if not (self.C > 0 and self.relative_C > 0 and self.absolute_weight >= 0):
            raise ValueError("C and relative_C must be > 0, absolute_weight >= 0")
        if self.min_reference_faces < 1 or self.folds < 2:
            raise ValueError("min_reference_faces >= 1 and folds >= 2 are needed")

    def weights_of(self, sets: np.ndarray) -> np.ndarray:
        """Sample weight (n,) of faces of the expression sets ``sets`` (n,)."""
        table = dict(self.set_weights)
        return np.array([table.get(str(s), 1.0) for s in sets], np.float64)


@dataclass
class Learned:
    """What :func:`learn` returns.

    Attributes
    ----------
    absolute, relative : FittedFaceClassifier
        The person-independent and relative models (relative None without people with
        enough faces).
    absolute_temperature, temperature, fused_temperature : float
        Of the absolute, relative and fused scores' softmax.
    absolute_weight : float
    counts : dict
        Faces each model learned from (``absolute``, ``relative``).
    """

    absolute: FittedFaceClassifier
    relative: FittedFaceClassifier | None
    absolute_temperature: float
    temperature: float
    fused_temperature: float
    absolute_weight: float
    counts: dict[str, int] = field(default_factory=dict)

    def absolute_probabilities(self, X: np.ndarray) -> np.ndarray:
        """Calibrated probabilities (n, C) of absolute vectors X (n, d)."""
        return softmax(self.absolute.scores(X), self.absolute_temperature)

    def fused_probabilities(self, X: np.ndarray, R: np.ndarray) -> np.ndarray:
        """Calibrated fused probabilities (n, C) of vectors X (n, d) with references R (n, d)."""
        if self.relative is None:
            return self.absolute_probabilities(X)
        return fuse(self.relative.scores(X - R), self.absolute.scores(X), self.temperature,
                    self.absolute_temperature, self.absolute_weight, self.fused_temperature)


def fuse(relative: np.ndarray, absolute: np.ndarray, temperature: float,
         absolute_temperature: float, absolute_weight: float,
         fused_temperature: float = 1.0) -> np.ndarray:
    """Fused probabilities (n, C): ``softmax((log p_rel + w log p_abs) / T_f)``."""
    log_rel = np.log(np.maximum(softmax(relative, temperature), 1e-300))
    log_abs = np.log(np.maximum(softmax(absolute, absolute_temperature), 1e-300))
    return softmax(log_rel + absolute_weight * log_abs, fused_temperature)


def person_references(X: np.ndarray, persons: np.ndarray, min_faces: int
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Each face's reference (n, d): the median of its person's faces, and which faces (n,)
    have one (people with at least ``min_faces`` faces)."""
    persons = np.asarray(persons).astype(str)
    names, index, counts = np.unique(persons, return_inverse=True, return_counts=True)
    has = counts[index] >= min_faces
    return poser_references(X, persons, has), has


def out_of_fold(fit: Callable[[np.ndarray], FittedFaceClassifier], classes: tuple[str, ...],
                X: np.ndarray, y: np.ndarray, persons: np.ndarray, folds: int) -> np.ndarray:
    """Scores (n, C) of every row by a model ``fit(train_mask)`` learned without its person.

    People are dealt round-robin (in sorted order) into ``folds`` folds. A class a fold's
    training rows lack gets a score far below the row's others (probability about 0).
    """
    names, index = np.unique(np.asarray(persons).astype(str), return_inverse=True)
    fold = index % min(folds, len(names))
    out = np.zeros((len(X), len(classes)))
    for k in np.unique(fold):
        test = fold == k
        model = fit(~test)
        scores = model.scores(X[test])
        columns = [model.classes.index(c) if c in model.classes else -1 for c in classes]
        floor = scores.min(axis=1, keepdims=True) - 30.0
        out[test] = np.where(np.array(columns) >= 0, scores[:, columns], floor)
    return out


def _temperature(scores: np.ndarray, y: np.ndarray, classes: tuple[str, ...]) -> float:
    known = np.isin(y, classes)
    if not known.any():
        return 1.0
    return fit_temperature(scores[known], np.searchsorted(np.array(classes), y[known]))


def learn(X: np.ndarray, y: np.ndarray, persons: np.ndarray, sets: np.ndarray,
          dims: Mapping[str, int], recipe: Recipe = Recipe(),
          note: Callable[[str], None] | None = None) -> Learned:
    """The absolute and relative models of vectors X (n, d) of classes y, people ``persons``
    and expression sets ``sets`` (module docstring).

    Raises
    ------
    ValueError
        With fewer than two classes.
    """
    y = np.asarray(y).astype(str)
    if len(np.unique(y)) < 2:
        raise ValueError(f"two classes or more are needed to learn, got {sorted(set(y))}")
    say = note or (lambda _: None)
    weight = recipe.weights_of(sets)
    every = np.ones(len(y), bool)

    def absolute(rows: np.ndarray, start: FittedFaceClassifier | None = None
                 ) -> FittedFaceClassifier:
        return fit_logistic(X[rows], y[rows], dims, C=recipe.C, sample_weight=weight[rows],
                            start=start)

    say(f"the person-independent model, on {len(y)} faces")
    model = absolute(every)
    scores = out_of_fold(lambda rows: absolute(rows, model), model.classes, X, y, persons,
                         recipe.folds)
    t_abs = _temperature(scores, y, model.classes)
    R, has = person_references(X, persons, recipe.min_reference_faces)
    learned = Learned(model, None, t_abs, 1.0, 1.0, recipe.absolute_weight,
                      {"absolute": len(y), "relative": int(has.sum())})
    if len(np.unique(y[has])) < 2:
        return learned
    D = X - R

    def relative(rows: np.ndarray, start: FittedFaceClassifier | None = None
                 ) -> FittedFaceClassifier:
        rows = rows & has
        return fit_logistic(D[rows], y[rows], dims, C=recipe.relative_C,
                            sample_weight=weight[rows], start=start)

    say(f"the relative model, on {int(has.sum())} faces of people with a reference")
    fitted = relative(every)
    if fitted.classes != model.classes:
        say(f"no relative model: the people with a reference show {list(fitted.classes)}, "
            f"not every class of {list(model.classes)}")
        return learned
    rel_scores = out_of_fold(lambda rows: relative(rows, fitted), fitted.classes, D, y,
                             persons, recipe.folds)[has]
    learned.relative = fitted
    learned.temperature = _temperature(rel_scores, y[has], fitted.classes)
    log_fused = np.log(np.maximum(fuse(rel_scores, scores[has], learned.temperature, t_abs,
                                       recipe.absolute_weight), 1e-300))
    learned.fused_temperature = _temperature(log_fused, y[has], model.classes)
    return learned
