"""The JAFFE expression benchmark behind ``aamtrack eval expression`` and the bench.

Every JAFFE image is fitted as the stack fits a frame
(:func:`~aamcore.expression.training.jaffe_faces`) and every row
(:class:`~aamcore.expression.variants.Variant`) is computed by the
pipeline's own code (:func:`~aamcore.expression.analysis.observe`, the
references of :mod:`.reference`), leave-one-poser-out over **all** faces of
the class set: a face without a fit or refused by the quality gate is
predicted :data:`~aamcore.expression.evaluation.NOT_CLASSIFIED`, counted
wrong, never dropped. Per fold (one poser held out):

- the gate's shape template is the mean canonical shape of the training
  posers' classifiable faces;
- each face's reference is the median of its poser's classifiable faces, of
  every class (no label is used; the test poser's is made of its own test
  images only), or for a ``causal`` row of the faces seen so far in a random order;
- the classifier is trained on the training posers' classifiable faces of the
  class set, its hyper-parameters (where it has any) chosen inside them.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from aamcore.expression.analysis import Observed, observe
from aamcore.expression.classifier_file import ExpressionClassifier
from aamcore.expression.evaluation import NOT_CLASSIFIED, ClassifierSpec, EvaluationResult
from aamcore.expression.evaluation import default_classifiers as thesis_classifiers
from aamcore.expression.face_classifier import fit_face_classifier
from aamcore.expression.labels import FIVE_CLASSES, SEVEN_CLASSES
from aamcore.expression.pipeline import ExpressionPipeline
from aamcore.expression.quality import landmark_problem
from aamcore.expression.spec import BLOCK_NAMES, FeatureConfig, QualityLimits
from aamcore.expression.svm import C_GRID, GAMMA_GRID
from aamcore.expression.training import (
    JaffeFaces,
    jaffe_faces,
    model_fingerprint,
    shape_template,
    train_deployed,
)
from aamcore.expression.variants import DEPLOYED, VARIANTS, Variant, fold_references
from aamcore.fitting.model import FittingModel

CLASS_SETS: dict[int, tuple[str, ...]] = {7: SEVEN_CLASSES, 5: FIVE_CLASSES}
TARGETS: dict[int, float] = {7: 0.75, 5: 0.85}
"""Leave-one-poser-out recognition rates the deployed pipeline must reach over all faces."""
PROCESS_TARGET_MS = 5.0
"""Median CPU time of one frame through the deployed pipeline (gate, features, classifier)."""
ALL_BLOCKS = FeatureConfig(blocks=BLOCK_NAMES)
"""Every block is computed once; a row takes the ones it names."""


def features_name(variant: Variant) -> str:
    """What a row classifies: ``"hog+shape, relative"``."""
    return "+".join(variant.blocks) + (", relative" if variant.relative else ", absolute")


def fold_usable(faces: JaffeFaces, observed: Observed, test: np.ndarray,
                limits: QualityLimits) -> tuple[np.ndarray, dict[int, str]]:
    """The faces usable in the fold testing ``test`` (n,), and why each refused test face is.

    The test faces pass the gate once more with the training posers' shape template.
    """
    ok = observed.ok
    template = shape_template(faces.observations, ok & ~test)
    why = {int(i): observed.problems[i] for i in np.flatnonzero(test & ~ok)}
    for i in np.flatnonzero(test & ok):
        problem = landmark_problem(faces.observations[i], limits, template)
        if problem:
            ok[i] = False
            why[int(i)] = problem
    return ok, why


def _fit(variant: Variant, Z: np.ndarray, y: np.ndarray, groups: np.ndarray,
         dims: dict[str, int], thesis: dict[str, ClassifierSpec]
         ) -> tuple[Callable[[np.ndarray], np.ndarray], dict[str, Any]]:
    """The fold's predictor of ``variant`` trained on Z (m, d), and its parameters."""
    if variant.classifier in thesis:
        estimator = thesis[variant.classifier].fit(Z, y, groups)
        params = {k: v for k, v in estimator.get_params().items()
                  if isinstance(v, int | float | str)}
        return estimator.predict, params
    fitted = fit_face_classifier(Z, y, groups, dims, variant.weights, variant.classifier)
    return fitted.predict, fitted.params


def evaluate_variant(
    faces: JaffeFaces,
    observed: Observed,
    variant: Variant,
    n_classes: int,
    limits: QualityLimits = QualityLimits(),
    thesis: dict[str, ClassifierSpec] | None = None,
) -> EvaluationResult:
    """Leave-one-poser-out of one row over every face of the class set (module docstring).

    Parameters
    ----------
    faces : JaffeFaces
    observed : Observed
        :func:`~aamcore.expression.analysis.observe` of ``faces.observations``
        with the variant's blocks (or more) and no template.
    variant : Variant
    n_classes : {7, 5}
    limits : QualityLimits
    thesis : dict, optional
        The thesis's classifiers by name (:func:`thesis_specs`).
    """
    thesis = thesis if thesis is not None else thesis_specs()
    names = CLASS_SETS[n_classes]
    labels, posers = faces.labels.astype(str), faces.posers.astype(str)
    in_set = np.isin(labels, names)
    X, dims = observed.vectors(variant.blocks), observed.dims(variant.blocks)
    y_pred = np.full(len(labels), NOT_CLASSIFIED, dtype=object)
    refused: list[str] = []
    params: dict[str, dict[str, Any]] = {}
    with threadpool_limits(limits=1):
        for poser in np.unique(posers):
            test = posers == poser
            ok, why = fold_usable(faces, observed, test, limits)
            refused += [f"{faces.names[i]}: {w}" for i, w in sorted(why.items()) if in_set[i]]
            Z = X - fold_references(X, labels, posers, ok, test, variant) if variant.relative \
                else X
            train, scored = ~test & in_set & ok, test & in_set & ok
            predict, params[str(poser)] = _fit(variant, Z[train], labels[train], posers[train],
                                               dims, thesis)
            if scored.any():
                y_pred[scored] = predict(Z[scored])
    return EvaluationResult(variant.name, features_name(variant), names, labels[in_set],
                            y_pred[in_set].astype(str), posers[in_set], params, refused)


def thesis_specs(n_trials: int = 25, C_grid: np.ndarray = C_GRID,
                 gamma_grid: np.ndarray = GAMMA_GRID) -> dict[str, ClassifierSpec]:
    """The thesis's classifiers by name: LDA+Mahalanobis, SVM OvA, SVM OvO, SVM DAG."""
    return {spec.name: spec for spec in thesis_classifiers(n_trials, C_grid, gamma_grid)}


@dataclass
class ExpressionBenchmark:
    """Results of :func:`run_expression_benchmark`.

    Attributes
    ----------
    results : dict
        ``results[row name][n_classes]``: an EvaluationResult.
    n_faces, n_fit_failed, n_no_face : int
        Faces in the benchmark, fits the fitter's test rejected, faces not found.
    model : str
        The fitting model's file name.
    process_ms : dict
        Median, mean and max CPU milliseconds of one frame through the
        deployed pipeline (empty when not measured).
    """

    results: dict[str, dict[int, EvaluationResult]]
    n_faces: int
    n_fit_failed: int
    n_no_face: int
    model: str = ""
    process_ms: dict[str, float] = field(default_factory=dict)

    def passed(self, n_classes: int) -> bool:
        """Whether the deployed row meets :data:`TARGETS` for the class count."""
        return self.results[DEPLOYED.name][n_classes].overall_rate >= TARGETS[n_classes]

    def process_passed(self) -> bool:
        return self.process_ms.get("median", np.inf) < PROCESS_TARGET_MS

    def checked(self) -> bool:
        """Whether the deployed row was run (the targets are its)."""
        return DEPLOYED.name in self.results

    def targets_met(self) -> bool:
        """Every target of the deployed row met (True when it was not run)."""
        if not self.checked():
            return True
        rates = all(self.passed(n) for n in self.results[DEPLOYED.name])
        return rates and (not self.process_ms or self.process_passed())

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable summary."""
        return {
            "protocol": "leave-one-poser-out on JAFFE, every face counted",
            "model": self.model, "n_faces": self.n_faces, "n_fit_failed": self.n_fit_failed,
            "n_no_face": self.n_no_face, "deployed": DEPLOYED.name,
            "targets": {str(k): v for k, v in TARGETS.items()},
            "process_ms": self.process_ms, "process_target_ms": PROCESS_TARGET_MS,
            "targets_met": self.targets_met(),
            "rows": {name: {str(n): r.to_dict() for n, r in by_n.items()}
                     for name, by_n in self.results.items()},
        }


def time_process(faces: JaffeFaces, model_path: str | Path, repeats: int = 3
                 ) -> dict[str, float]:
    """CPU milliseconds of one frame through the deployed pipeline.

    The classifier is trained on all faces, saved and reloaded; each poser's
    images, ``repeats`` times over, are one stream with the stream reference
    settings. CPU time, not wall time: the machine may be shared.
    """
    n_appearance = FittingModel.load(model_path).aam.n_appearance
    classifier = train_deployed(faces, n_appearance).classifier(model_fingerprint(model_path))
    with tempfile.TemporaryDirectory() as tmp:
        classifier = ExpressionClassifier.load(classifier.save(Path(tmp) / "c.npz"))
    times = []
    with threadpool_limits(limits=1):
        for poser in np.unique(faces.posers):
            pipeline = ExpressionPipeline(classifier)
            for i in np.tile(np.flatnonzero(faces.posers == poser), repeats):
                start = time.process_time()
                pipeline.process(faces.observations[i])
                times.append(time.process_time() - start)
    ms = 1e3 * np.array(times)
    return {"median": float(np.median(ms)), "mean": float(ms.mean()), "max": float(ms.max())}


def run_expression_benchmark(
    model_path: str | Path,
    folder: str | Path | None = None,
    variants: Sequence[Variant] = VARIANTS,
    class_counts: Sequence[int] = (7, 5),
    thesis: dict[str, ClassifierSpec] | None = None,
    progress: Callable[[str], None] | None = None,
    faces: JaffeFaces | None = None,
) -> ExpressionBenchmark:
    """Score every row for every class count over all faces; time the deployed pipeline.

    Parameters
    ----------
    model_path : path
        The fitting model that fits the faces.
    folder : path, optional
        JAFFE folder; ``<data root>/jaffe`` by default.
    variants : sequence of Variant
    class_counts : sequence of int
        7 and/or 5 (:data:`CLASS_SETS`).
    thesis : dict, optional
        The thesis's classifiers (:func:`thesis_specs`, full SVM grid by default).
    progress : callable, optional
        Called with a line of text after each row and class count.
    faces : JaffeFaces, optional
        Faces already fitted by ``model_path`` (then ``folder`` is not read).
    """
    unknown = sorted(set(class_counts) - set(CLASS_SETS))
    if unknown:
        raise ValueError(f"class counts {unknown} unknown (expected some of {list(CLASS_SETS)})")
    faces = faces if faces is not None else jaffe_faces(model_path, folder)
    observed = observe(faces.observations, ALL_BLOCKS)
    thesis = thesis if thesis is not None else thesis_specs()
    results: dict[str, dict[int, EvaluationResult]] = {}
    for variant in variants:
        results[variant.name] = {}
        for n in class_counts:
            started = time.perf_counter()
            result = evaluate_variant(faces, observed, variant, n, thesis=thesis)
            results[variant.name][n] = result
            if progress is not None:
                progress(f"{variant.name}, {n} classes: {100 * result.overall_rate:.1f}% of "
                         f"{result.n} ({time.perf_counter() - started:.0f} s)")
    bench = ExpressionBenchmark(results, len(faces.observations), int(faces.fit_failed.sum()),
                                int(faces.no_face.sum()), Path(model_path).name)
    if DEPLOYED in variants:
        bench.process_ms = time_process(faces, model_path)
    return bench
