"""The expression classifier for the fitting model in use: trained on first use, cached.

Landmarks and appearance vectors only make sense for the model and the
algorithm that fitted them, so the cached file is named after the model file's
fingerprint (a hash of its bytes), the fitting algorithm and the feature set
(:func:`classifier_path`), records them (``ExpressionClassifier.aam_fingerprint``
and ``info["algorithm"]``), and a classifier made for other fits is refused at
load (:func:`check_made_for`).

The ``deployed`` classifier learns from the training people of the three expression sets
(:func:`training_faces`: every JAFFE poser, the Taiwanese performers and the LFW people
outside their sets' held-out split, :mod:`aamcore.io.expression_sets`), each face seen as
the stack sees a stream's first frame (:func:`~aamcore.expression.faces.fit_faces`). Every
face the quality gate accepts is learned from (failed fits included: the fitter's
appearance test rejects many strongly expressive faces whose landmarks are right), by
:func:`~aamcore.expression.learning.learn` with :data:`RECIPE`: HOG patches and the
canonical shape, a person-independent and a relative logistic regression. The ``thesis``
feature set is the thesis's LDA + Mahalanobis on the absolute appearance ``c`` of JAFFE
(:func:`train_thesis`).
"""

from __future__ import annotations

import hashlib
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from aamcore import defaults
from aamcore.config import cache_dir
from aamcore.expression.analysis import Observed, observe
from aamcore.expression.calibration import fit_temperature, held_out_scores
from aamcore.expression.classifier_file import AAMMismatchError, ExpressionClassifier
from aamcore.expression.crop import canonical_shape
from aamcore.expression.faces import UNREADABLE, LabelledFaces, fit_faces
from aamcore.expression.labels import SEVEN_CLASSES
from aamcore.expression.learning import Learned, Recipe, learn
from aamcore.expression.pipeline import spec_fill
from aamcore.expression.quality import shape_deviation
from aamcore.expression.spec import STREAM_REFERENCE, FeatureConfig, PipelineSpec, QualityLimits
from aamcore.expression.thesis_classifiers import lda_mahalanobis_spec
from aamcore.fitting.config import FITTER, FitterConfig
from aamcore.fitting.model import FittingModel
from aamcore.io.expression_sets import EXPRESSION_SETS, load_expression_set
from aamcore.io.sample import DatasetError
from aamcore.model.cache import locked
from aamcore.progress import note, phase, plan

TRAINING_VERSION = 12
"""Bump when the training below changes, so that cached classifiers are retrained (3: the
RBF SVM of raw ``c``; 5: the face-feature pipeline; 6: keyed by algorithm and feature set;
7: the person-independent model beside the relative one; 8: temperatures fitted on ten
folds of one poser; 9: learned from the three expression sets by logistic regression, the
relative model on each person's median face, fused with the absolute one; 10: the
appearance block, the person-independent model a small network weighing each class of
each set alike with class biases fitted out of fold, the relative model on each person's
faces that look neutral; 11: the same arrays, the gate's sharpness limit that the file
carries from the training people's rule, 72 instead of 90; 12: the person-independent
network the mean of three seeds)."""
FEATURES = FeatureConfig(blocks=("hog", "shape", "appearance"))
"""The deployed feature blocks: HOG patches around the 51 inner landmarks of the canonical
crop, the 68 landmarks in the canonical frame and the AAM's appearance parameters ``c``
(zeros for a fit without them, :func:`~aamcore.expression.analysis.analyse_face`)."""
RECIPE = Recipe(C=1.0, relative_C=1.0, absolute_weight=0.25, min_reference_faces=1, folds=4,
                learner="network", hidden=64, alpha=0.01, epochs=40, seeds=3,
                balance="set_class", class_biases=True,
                min_neutral=float(STREAM_REFERENCE["min_neutral"]))
"""The deployed learning. Person-independent model, on the held-out people of the bench
(issue 46, each face a fresh stream; Taiwanese / LFW share right): logistic of HOG and shape
0.578 / 0.748 (neutral 2 of 20); with the appearance 0.607 / 0.781; each class of each set
weighed alike 0.656 / 0.684; the network (64 units) so weighed 0.676 / 0.618, with the
class biases 0.676 / 0.743 (neutral 17 of 20; seeds 1 and 2: 0.688 / 0.757 and 0.688 /
0.727). Three seeds averaged, against one, on three validation folds of the training
people (each face a fresh stream; the folds of
:func:`~aamcore.evaluation.expression_select.validation_folds`): Taiwanese 0.615 / 0.599
(neutral 0.67 / 0.63), LFW 0.758 / 0.745 (mean recall 0.507 / 0.486), JAFFE sessions 0.732
/ 0.709; five seeds 0.610 / 0.758 (0.486), 192 units of one seed 0.619 / 0.780 (0.486,
neutral 0.59), three seeds of 25 epochs 0.613 / 0.731. On the bench's held-out people
(``python -m bench expression --streams``, one seed against three): Taiwanese fresh 68.2 /
66.5 % (surprise 37 / 29 of 53, fear 20 / 23 of 43), LFW 72.2 / 74.7 % (mean recall 0.423 /
0.490), JAFFE sessions 75.6 / 77.0 %, streams' worst opening 54.0 / 56.6 %. Mirrored
copies of the training faces (the frame flipped, the fit's landmarks mirrored, ``c`` sampled
there), same folds: 40 epochs 0.626 / 0.773 (recall 0.493, neutral 0.59), 20 epochs 0.591 /
0.753; 80 epochs without them 0.613 / 0.783 (0.495, neutral 0.56): their gain is the extra
steps', and they cost the neutral face, so they are not used. L2 penalty 0.03 or 0.003, or
96 units a seed: within a point of these on every figure. Sessions (JAFFE / Taiwanese / LFW)
by the absolute weight 0.25, 1, 2: 0.732 / 0.621 / 0.740, 0.709 / 0.649 / 0.754, 0.690 /
0.641 / 0.758 (a trade between the sets, kept at 0.25). Out of fold,
the folds of training people: the network 0.66 of the Taiwanese performers and 0.73 of
JAFFE against 0.62 and 0.68 for the logistic model. Before (v9,
``bench_expression.py --select``): C 3 against 1 scored 0.572 against 0.563 for the
person-independent model; an absolute weight of 0.25 scored 0.642 against 0.588 for 0 once
sessions that open on an expression were scored (relative C 0.3)."""
CLASSIFIER_PHASES = (("fitting jaffe", 6.0), ("fitting taiwan_expressions", 17.0),
                     ("fitting lfw_expressions", 94.0), ("learning", 35.0))
"""The phases of training the deployed classifier with their seconds on a two-core machine
(load 5: 137 s in all with one seed, whose learning took 20 s; three seeds in two threads
took 37 s on a quiet machine; :func:`aamcore.progress.plan`)."""
FEATURE_SETS: dict[str, str] = {
    "deployed": "hog+shape+appearance, person-independent network and relative logistic, "
                "three sets",
    "thesis": "c, absolute, LDA+Mahalanobis (thesis), JAFFE",
}
"""Feature set -> what is trained."""


def model_fingerprint(model_path: str | Path) -> str:
    """A short hash of a fitting model file's bytes."""
    digest = hashlib.sha256(Path(model_path).read_bytes()).hexdigest()
    return digest[:16]


def training_selection(data: Any, limit: int | None = None) -> np.ndarray:
    """The faces (n,) of an :class:`~aamcore.io.expression_sets.ExpressionSet` a classifier
    learns from: those outside its held-out split, at most ``limit`` of each class when given
    (the first in the set's order; JAFFE is kept whole)."""
    keep = ~data.held_out()
    if limit is None or data.name == "jaffe":
        return keep
    labels = data.labels()
    for name in np.unique(labels):
        extra = np.flatnonzero(keep & (labels == name))[limit:]
        keep[extra] = False
    return keep


def training_faces(model_path: str | Path, config: FitterConfig = FITTER,
                   sets: Sequence[str] = EXPRESSION_SETS, limit: int | None = None
                   ) -> LabelledFaces:
    """The training faces of ``sets`` fitted by the model in ``model_path`` as the stack fits
    a stream's first frame (:func:`training_selection` of each; an unreadable image file is
    named, skipped and counted, :func:`~aamcore.expression.faces.fit_faces`).

    Raises
    ------
    DatasetError
        Naming a missing set, or a set without a face to learn from.
    """
    model = FittingModel.load(model_path)
    parts = []
    for name in sets:
        data = load_expression_set(name)
        parts.append(fit_faces(model, data, config, select=training_selection(data, limit)))
    return LabelledFaces.concatenate(parts)


def gated(faces: LabelledFaces, config: FeatureConfig, limits: QualityLimits,
          train: np.ndarray | None = None, appearance_dim: int | None = None
          ) -> tuple[Observed, np.ndarray, np.ndarray]:
    """The feature blocks of ``faces``, the faces (n,) the quality gate accepts (of ``train``
    when given; blurred or not), and the gate's shape template (68, 2): the mean canonical
    shape of the faces that pass the gate's other checks. With ``appearance_dim``, a fit
    without an appearance has zeros for it (:func:`~aamcore.expression.analysis.analyse_face`).

    Raises
    ------
    ValueError
        When no face passes the gate.
    """
    observed = observe(faces.observations, config, limits, appearance_dim=appearance_dim,
                       learn_blurred=True)
    ok = observed.learnable & (True if train is None else np.asarray(train, bool))
    if not ok.any():
        raise ValueError("no face passes the quality gate")
    template = np.mean([canonical_shape(faces.landmarks[i]) for i in np.flatnonzero(ok)],
                       axis=0)
    for i in np.flatnonzero(ok):
        ok[i] = shape_deviation(faces.landmarks[i], template) <= limits.max_shape_deviation
    return observed, ok, template


@dataclass
class DeployedModels:
    """What :func:`train_deployed` learns.

    Attributes
    ----------
    learned : Learned
        The person-independent and relative models and their temperatures.
    spec : PipelineSpec
    n_samples : int
        Faces learned from.
    """

    learned: Learned
    spec: PipelineSpec
    n_samples: int

    def classifier(self, fingerprint: str, info: Mapping[str, Any] | None = None
                   ) -> ExpressionClassifier:
        """The classifier file's contents for the fits of model ``fingerprint``."""
        notes = dict(info or {}) | {"samples": self.n_samples} | {
            f"samples_{k}": v for k, v in self.learned.counts.items()}
        return ExpressionClassifier.from_learned(self.learned, self.spec, fingerprint, notes)


def train_deployed(
    faces: LabelledFaces,
    appearance_dim: int,
    recipe: Recipe = RECIPE,
    limits: QualityLimits = QualityLimits(),
    reference: Mapping[str, Any] = STREAM_REFERENCE,
    train: np.ndarray | None = None,
    say: Callable[[str], None] | None = None,
) -> DeployedModels:
    """Learn the deployed models from every face of ``faces`` (of ``train`` (n,) when given)
    the quality gate accepts; ``reference`` holds the stream settings the spec carries to the
    library and the service.

    Raises
    ------
    ValueError
        When no face passes the gate, or the faces show fewer than two classes.
    """
    reference = dict(reference) | {"min_neutral": recipe.min_neutral}
    spec = PipelineSpec(FEATURES, appearance_dim, True, reference, limits)
    observed, ok, template = gated(faces, FEATURES, limits, train, spec_fill(spec))
    X, dims = observed.vectors(FEATURES.blocks)[ok], observed.dims(FEATURES.blocks)
    missing = sorted(set(SEVEN_CLASSES) - set(faces.labels[ok]))
    if missing and say is not None:
        say(f"no classifiable face of {', '.join(missing)} to learn from: the classifier "
            "will not know it")
    persons = np.char.add(np.char.add(faces.sets.astype(str), "/"), faces.posers.astype(str))
    with threadpool_limits(limits=1):
        learned = learn(X, faces.labels[ok], persons[ok], faces.sets[ok], dims, recipe, say)
    spec = PipelineSpec(FEATURES, appearance_dim, learned.relative is not None, reference,
                        limits, template)
    return DeployedModels(learned, spec, int(ok.sum()))


def train_thesis(
    faces: LabelledFaces,
    appearance_dim: int,
    limits: QualityLimits = QualityLimits(),
    reference: Mapping[str, Any] = STREAM_REFERENCE,
) -> tuple[Any, PipelineSpec, int, float]:
    """The thesis's classifier (LDA + Mahalanobis, its Fisher directions chosen by eq. 9.8)
    of the absolute appearance ``c`` of every classifiable face of ``faces`` with one.

    Returns
    -------
    estimator : FisherMahalanobis
    spec : PipelineSpec
    n_samples : int
    temperature : float
        Of its scores' softmax, fitted on held-out posers.
    """
    config = FeatureConfig(blocks=("appearance",))
    with_c = faces.subset(~faces.no_face & (np.isfinite(faces.appearance).all(axis=1)))
    if with_c.appearance.shape[1] != appearance_dim:
        raise ValueError(f"the faces' appearance has {with_c.appearance.shape[1]} values, "
                         f"the model {appearance_dim}")
    observed, train, template = gated(with_c, config, limits)
    X = observed.vectors(config.blocks)
    labels, posers = with_c.labels, with_c.posers

    def fit(Xt: np.ndarray, yt: np.ndarray, gt: np.ndarray) -> Any:
        return lda_mahalanobis_spec().fit(Xt, yt, gt).model_.scores

    with threadpool_limits(limits=1):
        estimator = lda_mahalanobis_spec().fit(X[train], labels[train], posers[train])
        scores = held_out_scores(fit, X[train], labels[train], posers[train])
    truth = np.searchsorted(np.array([str(c) for c in estimator.classes_]), labels[train])
    temperature = fit_temperature(scores, truth)
    spec = PipelineSpec(config, appearance_dim, False, dict(reference), limits, template)
    return estimator, spec, int(train.sum()), temperature


def train_classifier(model_path: str | Path, algorithm: str = FITTER.algorithm,
                     features: str = "deployed", limit: int | None = None
                     ) -> ExpressionClassifier:
    """The expression classifier of ``features`` (a key of :data:`FEATURE_SETS`) for the fits
    of ``model_path`` by ``algorithm``; with ``limit``, learned from at most ``limit`` faces
    of each class of each set besides JAFFE (a quick classifier for tests)."""
    if features not in FEATURE_SETS:
        raise ValueError(f"unknown expression features {features!r}: choose one of "
                         f"{list(FEATURE_SETS)}")
    # Every fit's landmarks and appearance are classified, failed ones too, so the failure
    # test (the default's) changes nothing the classifier learns.
    config = replace(FITTER, algorithm=algorithm)
    sets = ("jaffe",) if features == "thesis" else EXPRESSION_SETS
    start = time.perf_counter()
    faces = training_faces(model_path, config, sets, limit)
    n_appearance = FittingModel.load(model_path).aam.n_appearance
    info = {"training": FEATURE_SETS[features], "training_version": TRAINING_VERSION,
            "model": Path(model_path).name, "algorithm": algorithm, "features": features,
            "failure_test": config.failure_test, "limit": limit,
            "fit_failed": int(faces.fit_failed.sum()), "no_face": int(faces.no_face.sum()),
            "unreadable": int(np.char.startswith(faces.reasons.astype(str), UNREADABLE).sum()),
            "seconds_fitting": round(time.perf_counter() - start, 1)}
    fingerprint = model_fingerprint(model_path)
    start = time.perf_counter()
    with phase("learning"):
        if features == "thesis":
            estimator, spec, n, temperature = train_thesis(faces, n_appearance)
            return ExpressionClassifier.from_estimator(estimator, fingerprint, spec,
                                                       info | {"samples": n}, temperature)
        trained = train_deployed(faces, n_appearance, say=note)
        # features and learning: what the classifier adds to the fits
        info["seconds_learning"] = round(time.perf_counter() - start, 1)
        return trained.classifier(fingerprint, info)


def check_made_for(classifier: ExpressionClassifier, fingerprint: str, algorithm: str) -> None:
    """Refuse a classifier made for other fits than those of model ``fingerprint`` by
    ``algorithm``.

    Raises
    ------
    AAMMismatchError
        With one line naming what the classifier was made for and what it is given.
    """
    made = classifier.info.get("algorithm", defaults.ALGORITHM)
    if classifier.aam_fingerprint != fingerprint or made != algorithm:
        raise AAMMismatchError(
            f"this expression classifier was made for the fits of model "
            f"{classifier.aam_fingerprint} by {made}, not for those of model {fingerprint} by "
            f"{algorithm}: train one for these fits (aamtrack model prepare, with the same "
            "--profile or --algorithm)")


def classifier_path(model_path: str | Path, algorithm: str = FITTER.algorithm,
                    features: str = "deployed", limit: int | None = None) -> Path:
    """The cached classifier of ``features`` for the fits of ``model_path`` by ``algorithm``
    (learned from at most ``limit`` faces per class and set when given), trained on first
    use; the file's name holds them.

    Raises
    ------
    DatasetError
        When an expression set is missing or unreadable, or no face can be classified.
    """
    if features not in FEATURE_SETS:
        raise ValueError(f"unknown expression features {features!r}: choose one of "
                         f"{list(FEATURE_SETS)}")
    fingerprint = model_fingerprint(model_path)
    subset = "" if limit is None else f"-limit{limit}"
    path = cache_dir() / (f"expression-{fingerprint}-{algorithm}-{features}{subset}"
                          f"-v{TRAINING_VERSION}.npz")
    if path.is_file():
        return path
    with locked(path):  # another process training it: wait, and take what it saved
        if not path.is_file():
            _train_into(path, model_path, algorithm, features, limit)
    return path


def _train_into(path: Path, model_path: str | Path, algorithm: str, features: str,
                limit: int | None) -> None:
    note(f"training the {features} expression classifier for the fits of "
         f"{Path(model_path).name} by {algorithm}, once: it is kept in {path.parent}")
    try:
        with plan("training the expression classifier", CLASSIFIER_PHASES):
            classifier = train_classifier(model_path, algorithm, features, limit)
    except ValueError as exc:  # no classifiable face: nothing to train on
        if isinstance(exc, DatasetError):
            raise
        raise DatasetError(f"no expression classifier for {model_path}: {exc}") from exc
    tmp = path.with_name(f"{path.stem}.tmp{os.getpid()}.npz")
    classifier.save(tmp)
    tmp.replace(path)  # atomic: a reader never sees half a file
