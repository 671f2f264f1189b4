"""The expression models learned from labelled faces of many people (scikit-learn).

Two models of the face-feature vectors, classes weighted alike, each expression set
weighted as :class:`Recipe` says:

- the **person-independent** (absolute) model of the vectors themselves: it answers a
  stream's first frames, and any frame of a stream without a reference yet. A multinomial
  logistic regression (:func:`~aamcore.expression.face_classifier.fit_logistic`) or a small
  network (:func:`~aamcore.expression.network.fit_network`); with ``Recipe.class_biases``
  its classes are offset (:func:`~aamcore.expression.calibration.class_biases`) so that on
  people it never saw (its out-of-fold scores) the label it gives is right as often as it
  can be, neutral included;
- the **relative** model (logistic) of ``vector - reference``, where a face's reference is
  the per-feature median of its person's faces that the person-independent model, not
  having seen that person, calls neutral with probability ``Recipe.min_neutral`` or more:
  what the stream's reference (:class:`~aamcore.expression.reference.NeutralReference`)
  becomes over a session of that person. Only people with at least
  ``Recipe.min_reference_faces`` such faces train it.

Once a stream's reference is ready the two are fused: ``log p_rel + w log p_abs``
(``w = Recipe.absolute_weight``) through a softmax of its own temperature. The three
temperatures are fitted on out-of-fold scores, the folds made of whole people, so that a
probability means on new people what it says.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace

import numpy as np

from aamcore.expression.calibration import class_biases, fit_temperature, softmax
from aamcore.expression.network import fit_network
from aamcore.expression.reference import poser_references
from aamcore.expression.scores import FittedFaceClassifier

NEUTRAL = "NE"
"""The class a stream's reference estimates."""
THREADS = max(1, min(4, os.cpu_count() or 1))
"""Threads that learn models at once (the out-of-fold models, or the seeds of the network
learned from every face): scikit-learn's solvers spend most of their time in numpy, which
releases the GIL."""
LEARNERS = ("logistic", "network")
"""The person-independent models :class:`Recipe` may choose."""


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
    learner : str
        The person-independent model: ``"logistic"`` (``C``) or ``"network"``
        (:func:`~aamcore.expression.network.fit_network` with ``hidden``, ``alpha`` and
        ``epochs``).
    hidden, alpha, epochs, seeds
        Of the network (``seeds``: networks averaged, each of ``hidden`` units).
    balance : str
        How the person-independent model weighs its faces besides the set weights:
        ``"class"`` (each class alike) or ``"set_class"`` (each class of each set alike: a
        class one set rarely shows, as the Taiwanese performers' neutral face, weighs as
        much as the others of that set).
    class_biases : bool
        Offset the person-independent model's classes by
        :func:`~aamcore.expression.calibration.class_biases` of its out-of-fold scores.
    min_neutral : float
        Smallest out-of-fold probability of being neutral of a face that enters its person's
        reference (the stream's ``min_neutral``, :class:`~aamcore.expression.reference.
        NeutralReference`); a person needs ``min_reference_faces`` such faces.
    """

    C: float = 1.0
    relative_C: float = 1.0
    absolute_weight: float = 0.25
    set_weights: tuple[tuple[str, float], ...] = ()
    min_reference_faces: int = 3
    folds: int = 4
    learner: str = "logistic"
    hidden: int = 256
    alpha: float = 1e-2
    epochs: int = 60
    seeds: int = 1
    balance: str = "class"
    class_biases: bool = False
    min_neutral: float = 0.0

    def __post_init__(self) -> None:
        if not (self.C > 0 and self.relative_C > 0 and self.absolute_weight >= 0):
            raise ValueError("C and relative_C must be > 0, absolute_weight >= 0")
        if self.min_reference_faces < 1 or self.folds < 2:
            raise ValueError("min_reference_faces >= 1 and folds >= 2 are needed")
        if self.learner not in LEARNERS:
            raise ValueError(f"unknown learner {self.learner!r}: choose one of {LEARNERS}")
        if self.balance not in ("class", "set_class"):
            raise ValueError(f"unknown balance {self.balance!r}: class or set_class")

    def weights_of(self, sets: np.ndarray) -> np.ndarray:
        """Sample weight (n,) of faces of the expression sets ``sets`` (n,)."""
        table = dict(self.set_weights)
        return np.array([table.get(str(s), 1.0) for s in sets], np.float64)

    def absolute_weights(self, sets: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Sample weight (n,) of the person-independent model's faces of sets ``sets`` (n,)
        and classes ``y`` (n,): the set weights, times ``1 / faces of the set's class``
        with ``balance`` ``"set_class"`` (mean 1)."""
        weight = self.weights_of(sets)
        if self.balance == "set_class":
            cells = np.char.add(np.char.add(np.asarray(sets).astype(str), "/"),
                                np.asarray(y).astype(str))
            _, index, counts = np.unique(cells, return_inverse=True, return_counts=True)
            weight = weight / counts[index]
            weight *= len(weight) / weight.sum()
        return weight


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
    min_neutral : float
        Of the references the relative model learned from.
    """

    absolute: FittedFaceClassifier
    relative: FittedFaceClassifier | None
    absolute_temperature: float
    temperature: float
    fused_temperature: float
    absolute_weight: float
    counts: dict[str, int] = field(default_factory=dict)
    min_neutral: float = 0.0

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


def person_references(X: np.ndarray, persons: np.ndarray, min_faces: int,
                      usable: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Each face's reference (n, d): the median of its person's ``usable`` faces (n,) (all by
    default), and which faces (n,) have one (people with at least ``min_faces`` of them)."""
    persons = np.asarray(persons).astype(str)
    usable = np.ones(len(persons), bool) if usable is None else np.asarray(usable, bool)
    names, index = np.unique(persons, return_inverse=True)
    counts = np.bincount(index, weights=usable.astype(float), minlength=len(names))
    has = counts[index] >= min_faces
    return poser_references(X, persons, has & usable), has


def neutral_probability(probabilities: np.ndarray, classes: tuple[str, ...]) -> np.ndarray:
    """The neutral class's column (n,) of probabilities (n, C) (ones without one: every
    face may enter a reference)."""
    if NEUTRAL not in classes:
        return np.ones(len(probabilities))
    return np.asarray(probabilities)[:, classes.index(NEUTRAL)]


def out_of_fold(fit: Callable[[np.ndarray], FittedFaceClassifier], classes: tuple[str, ...],
                X: np.ndarray, y: np.ndarray, persons: np.ndarray, folds: int) -> np.ndarray:
    """Scores (n, C) of every row by a model ``fit(train_mask)`` learned without its person.

    People are dealt round-robin (in sorted order) into ``folds`` folds, whose models are
    learned in :data:`THREADS` threads (each seeded: the same scores however many). A class a
    fold's training rows lack gets a score far below the row's others (probability about 0).
    """
    names, index = np.unique(np.asarray(persons).astype(str), return_inverse=True)
    fold = index % min(folds, len(names))
    out = np.zeros((len(X), len(classes)))
    ks = np.unique(fold)
    with ThreadPoolExecutor(min(THREADS, len(ks))) as pool:
        models = list(pool.map(lambda k: fit(fold != k), ks))
    for k, model in zip(ks, models, strict=True):
        test = fold == k
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


def _biased(model: FittedFaceClassifier, scores: np.ndarray, y: np.ndarray, temperature: float
            ) -> tuple[FittedFaceClassifier, np.ndarray, float]:
    """The model and its out-of-fold scores (n, C) offset by the class biases of those scores
    (in score units: the biases times the temperature), and the temperature refitted."""
    known = np.isin(y, model.classes)
    truth = np.searchsorted(np.array(model.classes), y[known])
    offset = temperature * class_biases(scores[known] / temperature, truth)
    shifted = replace(model, model=model.model.shifted(offset),
                      params=model.params | {"class_biases": [round(float(v), 4)
                                                              for v in offset]})
    scores = scores + offset
    return shifted, scores, _temperature(scores, y, model.classes)


def learn(X: np.ndarray, y: np.ndarray, persons: np.ndarray, sets: np.ndarray,
          dims: Mapping[str, int], recipe: Recipe = Recipe(),
          note: Callable[[str], None] | None = None) -> Learned:
    """The absolute and relative models of vectors X (n, d) of classes y, people ``persons``
    and expression sets ``sets`` (module docstring); ValueError with fewer than two classes."""
    from aamcore.expression.face_classifier import fit_logistic  # serving reads Learned alone

    y = np.asarray(y).astype(str)
    if len(np.unique(y)) < 2:
        raise ValueError(f"two classes or more are needed to learn, got {sorted(set(y))}")
    say = note or (lambda _: None)
    weight, cells = recipe.weights_of(sets), recipe.absolute_weights(sets, y)
    every = np.ones(len(y), bool)

    def absolute(rows: np.ndarray, start: FittedFaceClassifier | None = None,
                 threads: int = 1) -> FittedFaceClassifier:
        if recipe.learner == "network":
            return fit_network(X[rows], y[rows], dims, recipe.hidden, recipe.alpha,
                               recipe.epochs, sample_weight=cells[rows], seeds=recipe.seeds,
                               threads=threads)
        return fit_logistic(X[rows], y[rows], dims, C=recipe.C, sample_weight=cells[rows],
                            start=start)

    say(f"the person-independent model ({recipe.learner}), on {len(y)} faces")
    model = absolute(every, threads=THREADS)  # the folds' models below run in threads
    scores = out_of_fold(lambda rows: absolute(rows, model), model.classes, X, y, persons,
                         recipe.folds)
    t_abs = _temperature(scores, y, model.classes)
    if recipe.class_biases:
        model, scores, t_abs = _biased(model, scores, y, t_abs)
    R, has = person_references(X, persons, recipe.min_reference_faces, neutral_probability(
        softmax(scores, t_abs), model.classes) >= recipe.min_neutral)
    learned = Learned(model, None, t_abs, 1.0, 1.0, recipe.absolute_weight,
                      {"absolute": len(y), "relative": int(has.sum())}, recipe.min_neutral)
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
