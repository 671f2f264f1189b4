"""The deployed recipe's choices, made on a validation split of the training people.

The held-out people of each set are never looked at: the training people of the three
sets are dealt into :data:`FOLDS` folds by person; each fold is scored by the recipe
learned from the other two. First the person-independent model (``C`` and the weight of
the Taiwanese faces), by the mean of four figures of the validation faces, each a fresh
stream: the accuracy of the labelled JAFFE, Taiwanese and LFW faces and the mean recall of
the LFW classes (the crowd's rare classes); then the relative model's ``C`` and the
absolute model's weight in the fused score, by the mean of three accuracies of the JAFFE and
Taiwanese validation people: each person's faces one session (JAFFE's and the Taiwanese),
and each person's faces of one expression one session (a stream that opens on that
expression: its reference is the expression itself).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np
from threadpoolctl import threadpool_limits

from aamcore.evaluation.expression_data import BenchFaces
from aamcore.evaluation.expression_heldout import (
    fold_models,
    fold_predictions,
    gate,
    result,
    session_references,
)
from aamcore.expression.crop import canonical_shape
from aamcore.expression.face_classifier import fit_logistic
from aamcore.expression.learning import Recipe, fuse

FOLDS = 3
C_GRID = (0.3, 1.0, 3.0)
TAIWAN_WEIGHTS = (1.0, 2.0, 4.0)
RELATIVE_C_GRID = (0.3, 1.0, 3.0)
ABSOLUTE_WEIGHTS = (0.0, 0.25, 0.5, 1.0)
SEEDS = (1, 2, 3, 5)
"""The network's seeds compared by :func:`seed_choices`."""


@dataclass
class Choice:
    """One candidate's validation figures and their mean (the score)."""

    recipe: Recipe
    figures: dict[str, float]

    @property
    def score(self) -> float:
        return float(np.mean(list(self.figures.values())))


def validation_folds(bench: BenchFaces, folds: int = FOLDS) -> list[np.ndarray]:
    """Validation masks (n,) over the training people, each person in one fold."""
    training = ~bench.held
    names = np.unique(bench.persons[training])
    order = np.random.default_rng(0).permutation(len(names))
    fold_of = dict(zip(names[order], np.arange(len(names)) % folds, strict=True))
    index = np.array([fold_of.get(p, -1) for p in bench.persons])
    return [training & (index == k) for k in range(folds)]


def _absolute_figures(bench: BenchFaces, recipe: Recipe, folds: list[np.ndarray]
                      ) -> dict[str, float]:
    training = ~bench.held
    predicted = np.full(len(bench.labels), "--", dtype=object)
    for valid in folds:
        train = training & ~valid & bench.learnable
        template = np.mean([canonical_shape(bench.faces.landmarks[i])
                            for i in np.flatnonzero(train)], axis=0)
        train &= gate(bench, template, learning=True)
        with threadpool_limits(limits=1):
            model = fit_logistic(bench.X[train], bench.labels[train], bench.dims, C=recipe.C,
                                 sample_weight=recipe.weights_of(bench.sets[train]))
        usable = valid & gate(bench, template)
        predicted[usable] = model.predict(bench.X[usable])
    return _figures(bench, predicted, np.any(folds, axis=0))


def _figures(bench: BenchFaces, predicted: np.ndarray, valid: np.ndarray) -> dict[str, float]:
    out = {}
    for name, short in (("jaffe", "JAFFE"), ("taiwan_expressions", "Taiwanese"),
                        ("lfw_expressions", "LFW")):
        r = result(short, bench, valid & (bench.sets == name), predicted)
        out[f"{short} right of labelled"] = r.labelled_accuracy
        if name == "lfw_expressions":
            out["LFW mean recall"] = r.mean_recall
    return out


def select_recipe(bench: BenchFaces, base: Recipe,
                  say: Callable[[str], None] | None = None) -> tuple[list[Choice],
                                                                     list[Choice]]:
    """Score the candidates (module docstring); the best of each list first."""
    folds = validation_folds(bench)
    absolute = []
    for C in C_GRID:
        for weight in TAIWAN_WEIGHTS:
            recipe = replace(base, C=C, set_weights=(("taiwan_expressions", weight),))
            absolute.append(Choice(recipe, _absolute_figures(bench, recipe, folds)))
            if say is not None:
                say(f"C {C}, Taiwanese weight {weight}: {absolute[-1].score:.3f}")
    absolute.sort(key=lambda c: -c.score)
    best = absolute[0].recipe
    relative = []
    posed = (bench.sets == "jaffe") | (bench.sets == "taiwan_expressions")
    for rel_C in RELATIVE_C_GRID:
        sessions = {w: np.full(len(bench.labels), "--", dtype=object) for w in ABSOLUTE_WEIGHTS}
        openings = {w: np.full(len(bench.labels), "--", dtype=object) for w in ABSOLUTE_WEIGHTS}
        for valid in folds:
            learned, template = fold_models(bench, ~bench.held & ~valid,
                                            replace(best, relative_C=rel_C))
            usable = valid & gate(bench, template)
            if learned.relative is None or not usable.any():
                continue
            X = bench.X[usable]
            R = session_references(bench, usable)[usable]
            opened = session_references(bench.labelled_as_persons(), usable)[usable]
            classes = np.array(learned.absolute.classes)
            for w in ABSOLUTE_WEIGHTS:
                for out, ref in ((sessions, R), (openings, opened)):
                    p = fuse(learned.relative.scores(X - ref), learned.absolute.scores(X),
                             learned.temperature, learned.absolute_temperature, w)
                    out[w][usable] = classes[p.argmax(axis=1)]
        valid = np.any(folds, axis=0)
        for w in ABSOLUTE_WEIGHTS:
            figures = {f"{short} session right of labelled": result(
                short, bench, valid & (bench.sets == name), sessions[w]).labelled_accuracy
                for name, short in (("jaffe", "JAFFE"), ("taiwan_expressions", "Taiwanese"))}
            figures["opening sessions right of labelled"] = result(
                "opening", bench, valid & posed, openings[w]).labelled_accuracy
            relative.append(Choice(replace(best, relative_C=rel_C, absolute_weight=w), figures))
        if say is not None:
            say(f"relative C {rel_C}: " + ", ".join(f"w {c.recipe.absolute_weight} "
                                                    f"{c.score:.3f}" for c in relative[-4:]))
    relative.sort(key=lambda c: -c.score)
    return absolute, relative


def seed_choices(bench: BenchFaces, base: Recipe, seeds: Sequence[int] = SEEDS,
                 say: Callable[[str], None] | None = None) -> list[Choice]:
    """The deployed recipe with each count of ``seeds`` averaged, scored on the validation
    folds (each face a fresh stream): the figures of the first stage of
    :func:`select_recipe` and the Taiwanese neutral faces' recall; the best first."""
    folds = validation_folds(bench)
    valid = np.any(folds, axis=0)
    neutral = valid & (bench.sets == "taiwan_expressions") & (bench.labels == "NE")
    choices = []
    for n in seeds:
        recipe = replace(base, seeds=n)
        fresh = np.full(len(bench.labels), "--", dtype=object)
        for fold in folds:
            learned, template = fold_models(bench, ~bench.held & ~fold, recipe)
            fresh[fold] = fold_predictions(bench, learned, template, fold)[0][fold]
        figures = _figures(bench, fresh, valid)
        figures["Taiwanese neutral recall"] = float(np.mean(fresh[neutral] == "NE"))
        choices.append(Choice(recipe, figures))
        if say is not None:
            say(f"{n} seeds: {choices[-1].score:.3f}")
    return sorted(choices, key=lambda c: -c.score)


def format_choices(title: str, choices: Sequence[Choice], keys: Sequence[str]) -> str:
    """The candidates' table, best first."""
    names = list(choices[0].figures) if choices else []
    lines = [title, "", "| " + " | ".join(keys) + " | " + " | ".join(names) + " | score |",
             "|---" * (len(keys) + len(names) + 1) + "|"]
    for c in choices:
        values = {"C": c.recipe.C, "Taiwanese weight": dict(c.recipe.set_weights).get(
            "taiwan_expressions", 1.0), "relative C": c.recipe.relative_C,
            "absolute weight": c.recipe.absolute_weight, "seeds": c.recipe.seeds}
        lines.append("| " + " | ".join(f"{values[k]:g}" for k in keys) + " | "
                     + " | ".join(f"{100 * v:.1f}" if "right" in n else f"{v:.3f}"
                                  for n, v in c.figures.items()) + f" | {c.score:.3f} |")
    return "\n".join(lines)
