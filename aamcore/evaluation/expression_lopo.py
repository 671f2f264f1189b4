"""JAFFE's protocol for JAFFE-only pipelines, behind ``aamtrack eval expression``.

Every JAFFE image is fitted as the stack fits a frame (:func:`jaffe_faces`) and
every row (:class:`~aamcore.evaluation.expression_variants.Variant`, trained on the
other JAFFE posers alone) is computed by the pipeline's own code
(:func:`~aamcore.expression.analysis.observe`, the references of
:mod:`aamcore.expression.reference`), leave-one-poser-out over **all** faces of
the class set: a face without a fit or refused by the quality gate is
predicted :data:`~aamcore.evaluation.expression_results.NOT_CLASSIFIED`, counted
wrong, never dropped. Per fold (one poser held out):

- the gate's shape template is the mean canonical shape of the training
  posers' classifiable faces;
- each face's reference is the median of its poser's classifiable faces, of
  every class (no label is used; the test poser's is made of its own test
  images only), or for a ``causal`` row of the faces seen so far in a random order;
- the classifier is trained on the training posers' classifiable faces of the
  class set, its hyper-parameters (where it has any) chosen inside them.

The deployed classifier, learned from three expression sets, has its own JAFFE row in
:mod:`.expression_heldout`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from aamcore.evaluation.expression_results import NOT_CLASSIFIED, EvaluationResult
from aamcore.evaluation.expression_variants import VARIANTS, Variant, fold_references
from aamcore.expression.analysis import Observed, observe
from aamcore.expression.crop import canonical_shape
from aamcore.expression.face_classifier import fit_face_classifier
from aamcore.expression.faces import LabelledFaces, fit_faces
from aamcore.expression.labels import FIVE_CLASSES, SEVEN_CLASSES
from aamcore.expression.quality import landmark_problem
from aamcore.expression.spec import BLOCK_NAMES, FeatureConfig, QualityLimits
from aamcore.expression.svm import C_GRID, GAMMA_GRID
from aamcore.expression.thesis_classifiers import ClassifierSpec
from aamcore.expression.thesis_classifiers import default_classifiers as thesis_classifiers
from aamcore.fitting.config import FITTER, FitterConfig
from aamcore.fitting.model import FittingModel
from aamcore.io.expression_sets import load_expression_set

CLASS_SETS: dict[int, tuple[str, ...]] = {7: SEVEN_CLASSES, 5: FIVE_CLASSES}
ALL_BLOCKS = FeatureConfig(blocks=BLOCK_NAMES)
"""Every block is computed once; a row takes the ones it names."""


def jaffe_faces(model_path: str | Path, folder: str | Path | None = None,
                config: FitterConfig = FITTER) -> LabelledFaces:
    """Every JAFFE image fitted by the model in ``model_path`` as ``config`` says, with its
    class and poser (the images kept).

    Raises
    ------
    DatasetError
        When the folder is missing or holds an unreadable JAFFE file.
    """
    return fit_faces(FittingModel.load(model_path), load_expression_set("jaffe", folder), config,
                     keep_images=True)


def shape_template(faces: LabelledFaces, usable: np.ndarray) -> np.ndarray:
    """Mean canonical shape (68, 2) of the usable faces' landmarks."""
    if not np.any(usable):
        raise ValueError("no usable face to make a shape template from")
    return np.mean([canonical_shape(faces.landmarks[i]) for i in np.flatnonzero(usable)],
                   axis=0)


def features_name(variant: Variant) -> str:
    """What a row classifies: ``"hog+shape, relative"``."""
    return "+".join(variant.blocks) + (", relative" if variant.relative else ", absolute")


def fold_usable(faces: LabelledFaces, observed: Observed, test: np.ndarray,
                limits: QualityLimits) -> tuple[np.ndarray, dict[int, str]]:
    """The faces usable in the fold testing ``test`` (n,), and why each refused test face is.

    The test faces pass the gate once more with the training posers' shape template.
    """
    ok = observed.ok
    template = shape_template(faces, ok & ~test)
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
    faces: LabelledFaces,
    observed: Observed,
    variant: Variant,
    n_classes: int,
    limits: QualityLimits = QualityLimits(),
    thesis: dict[str, ClassifierSpec] | None = None,
) -> EvaluationResult:
    """Leave-one-poser-out of one row over every face of the class set (module docstring).

    Parameters
    ----------
    faces : LabelledFaces
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
    """

    results: dict[str, dict[int, EvaluationResult]]
    n_faces: int
    n_fit_failed: int
    n_no_face: int
    model: str = ""

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable summary."""
        return {
            "protocol": "leave-one-poser-out on JAFFE, every face counted",
            "model": self.model, "n_faces": self.n_faces, "n_fit_failed": self.n_fit_failed,
            "n_no_face": self.n_no_face,
            "rows": {name: {str(n): r.to_dict() for n, r in by_n.items()}
                     for name, by_n in self.results.items()},
        }


def run_expression_benchmark(
    model_path: str | Path,
    folder: str | Path | None = None,
    variants: Sequence[Variant] = VARIANTS,
    class_counts: Sequence[int] = (7, 5),
    thesis: dict[str, ClassifierSpec] | None = None,
    progress: Callable[[str], None] | None = None,
    faces: LabelledFaces | None = None,
) -> ExpressionBenchmark:
    """Score every row for every class count over all faces.

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
    faces : LabelledFaces, optional
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
    return ExpressionBenchmark(results, len(faces.labels), int(faces.fit_failed.sum()),
                               int(faces.no_face.sum()), Path(model_path).name)
