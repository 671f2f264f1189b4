"""The expression benchmark on people the classifier never saw (``bench/bench_expression.py``).

Every face is one of :func:`~aamcore.evaluation.expression_data.bench_faces`. The rows:

- **held out**: the deployed classifier on the held-out people of ``taiwan_expressions``
  and ``lfw_expressions`` (:mod:`aamcore.io.expression_sets`), each face a fresh stream
  through :class:`~aamcore.expression.pipeline.ExpressionPipeline` (what a user's first
  frames get: the person-independent model), and each person's faces as one session
  (the reference the stream's running median becomes over them, fused with it);
- **JAFFE, leave one poser out**: the recipe trained on the training people of the other
  sets and nine posers, tested on the tenth (fresh and session);
- **cross-set**: the recipe trained without a set, tested on its held-out people (all of
  JAFFE);
- a peer (the ``fer`` network) on the same faces, where given.

A face the pipeline refuses (no face, the quality gate) is not labelled: each row gives
the share labelled, the accuracy of the labelled faces, each class's recall among them and
their mean (:class:`~aamcore.evaluation.expression_results.EvaluationResult`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from threadpoolctl import threadpool_limits

from aamcore.evaluation.expression_data import BenchFaces
from aamcore.evaluation.expression_results import NOT_CLASSIFIED, EvaluationResult
from aamcore.expression.classifier_file import ExpressionClassifier
from aamcore.expression.crop import canonical_shape
from aamcore.expression.labels import SEVEN_CLASSES
from aamcore.expression.learning import (
    Learned,
    Recipe,
    learn,
    neutral_probability,
    person_references,
)
from aamcore.expression.pipeline import ExpressionPipeline
from aamcore.expression.quality import shape_deviation
from aamcore.expression.spec import QualityLimits

Peer = Callable[[np.ndarray], tuple[str | None, np.ndarray | None]]
"""A classifier of whole images (a peer): its label (a JAFFE class code) and probabilities,
or (None, None) when it finds no face."""
SHORT = {"jaffe": "JAFFE", "taiwan_expressions": "Taiwanese", "lfw_expressions": "LFW"}


@dataclass
class Table:
    """Rows of one table: their results by name, and what was said about the faces."""

    title: str
    rows: dict[str, EvaluationResult] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


def gate(bench: BenchFaces, template: np.ndarray, limits: QualityLimits = QualityLimits(),
         learning: bool = False) -> np.ndarray:
    """Faces (n,) the whole gate accepts: the gate's other checks, then the shape template
    (``learning``: those a recipe learns from, blurred or not)."""
    ok = (bench.learnable if learning else bench.ok).copy()
    for i in np.flatnonzero(ok):
        ok[i] = shape_deviation(bench.faces.landmarks[i], template) <= limits.max_shape_deviation
    return ok


def result(name: str, bench: BenchFaces, mask: np.ndarray, predicted: np.ndarray
           ) -> EvaluationResult:
    """The row ``name`` of the faces ``mask`` (n,) with predictions (n,) (``NOT_CLASSIFIED``
    where unlabelled)."""
    return EvaluationResult(name, "hog+shape", SEVEN_CLASSES, bench.labels[mask].astype(str),
                            predicted[mask].astype(str), bench.persons[mask])


def session_references(bench: BenchFaces, usable: np.ndarray,
                       neutral: np.ndarray | None = None) -> np.ndarray:
    """Each face's session reference (n, d): the median of its person's usable faces (that
    look ``neutral`` (n,) when given; zero for a person without one)."""
    kept = usable if neutral is None else usable & neutral
    return person_references(bench.X, np.where(usable, bench.persons, ""), 1, kept)[0]


def sessions(bench: BenchFaces, usable: np.ndarray, p_abs: np.ndarray,
             classes: tuple[str, ...], min_neutral: float) -> tuple[np.ndarray, np.ndarray]:
    """The session references (m, d) of the ``usable`` faces (n,) (m of them) whose
    person-independent probabilities are ``p_abs`` (m, C), each the median of its person's
    faces that look neutral (:class:`~aamcore.expression.reference.NeutralReference`), and
    which of them (m,) have one."""
    neutral = np.zeros(len(bench.labels), bool)
    neutral[usable] = neutral_probability(p_abs, classes) >= min_neutral
    R = session_references(bench, usable, neutral)[usable]
    people = bench.persons[usable]
    return R, np.isin(people, people[neutral[usable]])


def fold_models(bench: BenchFaces, train: np.ndarray, recipe: Recipe
                ) -> tuple[Learned, np.ndarray]:
    """The recipe learned from the faces ``train`` (n,) the gate accepts, and the gate's
    shape template made of them."""
    ok = bench.learnable & train
    template = np.mean([canonical_shape(bench.faces.landmarks[i]) for i in np.flatnonzero(ok)],
                       axis=0)
    ok &= gate(bench, template, learning=True)
    with threadpool_limits(limits=1):
        learned = learn(bench.X[ok], bench.labels[ok], bench.persons[ok], bench.sets[ok],
                        bench.dims, recipe)
    return learned, template


def fold_predictions(bench: BenchFaces, learned: Learned, template: np.ndarray,
                     test: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fresh-stream and session predictions (n,) of the faces ``test`` by fold models."""
    usable = test & gate(bench, template)
    fresh = np.full(len(bench.labels), NOT_CLASSIFIED, dtype=object)
    session = fresh.copy()
    if usable.any():
        classes = np.array(learned.absolute.classes)
        X = bench.X[usable]
        p_abs = learned.absolute_probabilities(X)
        fresh[usable] = classes[p_abs.argmax(axis=1)]
        R, has = sessions(bench, usable, p_abs, learned.absolute.classes, learned.min_neutral)
        p = np.where(has[:, None], learned.fused_probabilities(X, R), p_abs)
        session[usable] = classes[p.argmax(axis=1)]
    return fresh, session


def deployed_predictions(bench: BenchFaces, classifier: ExpressionClassifier,
                         test: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """The deployed classifier's fresh-stream predictions (n,) of the faces ``test``, each
    through a new :class:`ExpressionPipeline`, its session predictions (n,), and the reasons
    of the faces refused."""
    pipeline = ExpressionPipeline(classifier)
    fresh = np.full(len(bench.labels), NOT_CLASSIFIED, dtype=object)
    reasons = []
    for i in np.flatnonzero(test):
        pipeline.reset()
        estimate = pipeline.process(bench.faces.observation(int(i)))
        if estimate.label is None:
            reasons.append(f"{bench.faces.names[i]}: {estimate.reason}")
        else:
            fresh[i] = estimate.label
    session = np.full(len(bench.labels), NOT_CLASSIFIED, dtype=object)
    usable = test & (fresh != NOT_CLASSIFIED)
    if usable.any() and classifier.absolute is not None:
        X = bench.X[usable]
        p_abs = classifier.absolute_probabilities(X)
        R, has = sessions(bench, usable, p_abs, classifier.class_names, min_neutral(classifier))
        p = np.where(has[:, None], classifier.fused_probabilities(X - R, X), p_abs)
        session[usable] = np.array(classifier.class_names)[p.argmax(axis=1)]
    return fresh, session, reasons


def peer_predictions(bench: BenchFaces, peer: Peer, test: np.ndarray,
                     memo: dict[str, str | None]) -> np.ndarray:
    """A peer's label (n,) of each face ``test`` from its image (``memo``: by file)."""
    out = np.full(len(bench.labels), NOT_CLASSIFIED, dtype=object)
    for i in np.flatnonzero(test):
        path = str(bench.faces.paths[i])
        if path not in memo:
            memo[path] = peer(bench.faces.image(int(i)))[0]
        out[i] = memo[path] or NOT_CLASSIFIED
    return out


def held_out_tables(bench: BenchFaces, classifier: ExpressionClassifier,
                    peer: tuple[str, Peer] | None = None,
                    memo: dict[str, str | None] | None = None) -> list[Table]:
    """The deployed classifier (and the peer) on the held-out people of each set."""
    tables = []
    held = bench.held
    for name in ("taiwan_expressions", "lfw_expressions"):
        test = held & (bench.sets == name)
        table = Table(f"{SHORT[name]} held out: {int(test.sum())} faces of "
                      f"{len(np.unique(bench.persons[test]))} people never trained on")
        fresh, session, refused = deployed_predictions(bench, classifier, test)
        table.rows["deployed, each face a fresh stream (person-independent)"] = result(
            "fresh", bench, test, fresh)
        table.rows["deployed, each person's faces one session (reference + fused)"] = result(
            "session", bench, test, session)
        if peer is not None:
            table.rows[peer[0]] = result(peer[0], bench, test,
                                         peer_predictions(bench, peer[1], test, memo or {}))
        table.notes += _missing(table) + _refusals(refused)
        tables.append(table)
    return tables


def jaffe_lopo_table(bench: BenchFaces, recipe: Recipe, peer: tuple[str, Peer] | None = None,
                     memo: dict[str, str | None] | None = None,
                     say: Callable[[str], None] | None = None) -> Table:
    """JAFFE leave one poser out: per poser, the recipe learned from the training people of
    the other sets and the other posers."""
    jaffe = bench.sets == "jaffe"
    trainable = ~bench.held
    fresh = np.full(len(bench.labels), NOT_CLASSIFIED, dtype=object)
    session = fresh.copy()
    for poser in np.unique(bench.persons[jaffe]):
        test = bench.persons == poser
        learned, template = fold_models(bench, trainable & ~test, recipe)
        f, s = fold_predictions(bench, learned, template, test)
        fresh[test], session[test] = f[test], s[test]
        if say is not None:
            right = np.mean(s[test] == bench.labels[test])
            say(f"JAFFE poser {poser}: session {100 * right:.1f}%")
    table = Table(f"JAFFE, leave one poser out ({int(jaffe.sum())} faces of 10 posers; the "
                  "recipe learned from the other sets' training people and 9 posers)")
    table.rows["recipe, each face a fresh stream"] = result("fresh", bench, jaffe, fresh)
    table.rows["recipe, the poser's faces one session (JAFFE's protocol)"] = result(
        "session", bench, jaffe, session)
    if peer is not None:
        table.rows[peer[0]] = result(peer[0], bench, jaffe,
                                     peer_predictions(bench, peer[1], jaffe, memo or {}))
    table.notes += _missing(table)
    return table


def cross_set_table(bench: BenchFaces, recipe: Recipe, sets: Sequence[str]) -> Table:
    """Per set: the recipe learned without it, tested on its held-out people (all of JAFFE),
    each face a fresh stream and each person's faces one session."""
    table = Table("cross-set: learned without the set, tested on it (held-out people; JAFFE: "
                  "all)")
    for name in sets:
        test = (bench.sets == name) & (bench.held | (bench.sets == "jaffe"))
        learned, template = fold_models(bench, ~bench.held & (bench.sets != name), recipe)
        fresh, session = fold_predictions(bench, learned, template, test)
        table.rows[f"{SHORT[name]}, fresh"] = result("fresh", bench, test, fresh)
        table.rows[f"{SHORT[name]}, session"] = result("session", bench, test, session)
    table.notes += _missing(table)
    return table


def _missing(table: Table) -> list[str]:
    return [f"{name}: no face of {', '.join(r.missing_classes)} here (not scored)"
            for name, r in table.rows.items() if r.missing_classes]


def _refusals(reasons: list[str]) -> list[str]:
    if not reasons:
        return []
    keys: dict[str, int] = {}
    for reason in reasons:
        key = reason.split(": ", 1)[1].split(":", 1)[0]
        keys[key] = keys.get(key, 0) + 1
    return ["not labelled: " + ", ".join(f"{n} {k}" for k, n in sorted(keys.items()))]


@dataclass
class Match:
    """Served against trained references, over the faces of a set's held-out people."""

    people: int
    faces: int
    max_difference: float
    agree: int


def served_match(bench: BenchFaces, classifier: ExpressionClassifier,
                 name: str = "taiwan_expressions") -> Match:
    """Each held-out person's classifiable faces streamed through an
    :class:`ExpressionPipeline` (each face for ``stride`` frames, as a held expression is),
    against the reference the training gives that person (the median of the same faces that
    look neutral), people with such a face:
    the largest difference of the two references and how many faces the fused model labels
    alike with either."""
    test = bench.held & (bench.sets == name)
    _, session, _ = deployed_predictions(bench, classifier, test)
    usable = test & (session != NOT_CLASSIFIED)
    stride = int(classifier.pipeline.reference["stride"])
    worst, agree = 0.0, 0
    assert classifier.absolute is not None
    trained, has = sessions(bench, usable, classifier.absolute_probabilities(bench.X[usable]),
                            classifier.class_names, min_neutral(classifier))
    names = np.unique(bench.persons[usable][has])
    trained_of = dict(zip(bench.persons[usable], trained, strict=True))
    for person in names:
        members = np.flatnonzero(usable & (bench.persons == person))
        pipeline = ExpressionPipeline(classifier)
        for i in members:
            observation = bench.faces.observation(int(i))
            for _ in range(stride):
                pipeline.process(observation)
        served = pipeline.reference.reference()
        worst = max(worst, float(np.abs(served - trained_of[person]).max()))
        X = bench.X[members]
        p = classifier.fused_probabilities(X - served, X)
        agree += int(np.sum(np.array(classifier.class_names)[p.argmax(axis=1)]
                            == session[members]))
    return Match(len(names), int(np.isin(bench.persons[usable], names).sum()), worst, agree)


def min_neutral(classifier: ExpressionClassifier) -> float:
    """The neutral probability a face needs to enter the classifier's stream reference."""
    return float(classifier.pipeline.reference.get("min_neutral", 0.0))


def process_ms(bench: BenchFaces, classifier: ExpressionClassifier, repeats: int = 3
               ) -> np.ndarray:
    """CPU milliseconds (m,) of each frame through :meth:`ExpressionPipeline.process` (gate,
    features, reference, classifier): each held-out Taiwanese performer's faces, ``repeats``
    times over, one stream. CPU time, not wall time: the machine may be shared."""
    import time

    test = bench.held & (bench.sets == "taiwan_expressions")
    times = []
    with threadpool_limits(limits=1):
        for person in np.unique(bench.persons[test]):
            pipeline = ExpressionPipeline(classifier)
            members = np.flatnonzero(test & (bench.persons == person))
            observations = [bench.faces.observation(int(i)) for i in members]
            for observation in observations * repeats:
                start = time.process_time()
                pipeline.process(observation)
                times.append(time.process_time() - start)
    return 1e3 * np.array(times)
