"""The expression classifier for the fitting model in use: trained on JAFFE on first use, cached.

Landmarks and appearance vectors only make sense for the model and the
algorithm that fitted them, so the cached file is named after the model file's
fingerprint (a hash of its bytes), the fitting algorithm and the feature set
(:func:`classifier_path`), records them (``ExpressionClassifier.aam_fingerprint``
and ``info["algorithm"]``), and a classifier made for other fits is refused at
load (:func:`check_made_for`).

Training sees each JAFFE face as the stack sees a frame (:func:`stack_observations`):
a new stream, the Haar detector with the detector service's settings, the
fitter with the default algorithm and failure test, the landmarks and ``c``
at the precision of the ``Fit`` message. It then learns the feature set's
variant on every face the quality gate accepts (failed fits included: the
fitter's appearance test rejects many strongly expressive faces whose
landmarks are right): ``deployed`` (:data:`~aamcore.expression.variants.DEPLOYED`),
each face relative to the median of its poser's faces (:func:`train_deployed`),
or ``thesis``, the thesis's LDA + Mahalanobis on the absolute appearance ``c``
(:func:`train_thesis`).
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from aamcore import defaults
from aamcore.config import cache_dir
from aamcore.detection.haar import HaarFaceDetector
from aamcore.expression.analysis import observe
from aamcore.expression.calibration import fit_temperature, held_out_scores
from aamcore.expression.classifier_file import AAMMismatchError, ExpressionClassifier
from aamcore.expression.crop import FaceObservation, canonical_shape
from aamcore.expression.face_classifier import FittedFaceClassifier, fit_face_classifier
from aamcore.expression.labels import SEVEN_CLASSES
from aamcore.expression.pipeline import NEUTRAL
from aamcore.expression.quality import landmark_problem
from aamcore.expression.reference import poser_references
from aamcore.expression.spec import STREAM_REFERENCE, PipelineSpec, QualityLimits
from aamcore.expression.variants import DEPLOYED, Variant, variant_named
from aamcore.fitting.config import FITTER, FitterConfig
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.fitting.result import appearance_of
from aamcore.fitting.tracker import Tracker
from aamcore.io.jaffe import load_jaffe
from aamcore.io.sample import DatasetError
from aamcore.progress import note, phase, plan, progress

TRAINING_VERSION = 8
"""Bump when the training below changes, so that cached classifiers are retrained (3: the
RBF SVM of raw ``c``; 4 was the research branch's; 5: the face-feature pipeline; 6: keyed
by algorithm and feature set, the thesis's LDA + Mahalanobis on ``c``; 7: the
person-independent model beside the relative one, temperatures fitted on held-out posers;
8: the temperatures fitted on ten folds of one poser)."""
CLASSIFIER_PHASES = (("fitting JAFFE", 5.0), ("classifier", 6.0))
"""The phases of training a classifier with their seconds on a quiet two-core machine
(:func:`aamcore.progress.plan`)."""
FEATURE_SETS: dict[str, str] = {
    "deployed": DEPLOYED.name,
    "thesis": "c, absolute, LDA+Mahalanobis (thesis)",
}
"""Feature set -> the variant (:data:`~aamcore.expression.variants.VARIANTS`) trained."""


def model_fingerprint(model_path: str | Path) -> str:
    """A short hash of a fitting model file's bytes."""
    digest = hashlib.sha256(Path(model_path).read_bytes()).hexdigest()
    return digest[:16]


@dataclass
class JaffeFaces:
    """Every JAFFE image as the stack observes it.

    Attributes
    ----------
    observations : list of n FaceObservation
    labels, posers, names : (n,) str arrays
        Class, poser and file name of each face.
    """

    observations: list[FaceObservation]
    labels: np.ndarray
    posers: np.ndarray
    names: np.ndarray

    @property
    def fit_failed(self) -> np.ndarray:
        """Faces (n,) whose fit the fitter's own test rejected (they are still classified)."""
        return np.array([o.fit_failed for o in self.observations], dtype=bool)

    @property
    def no_face(self) -> np.ndarray:
        """Faces (n,) without landmarks (no detection)."""
        return np.array([o.landmarks.size == 0 for o in self.observations], dtype=bool)


def stack_observations(model: FittingModel, images: Iterable[np.ndarray],
                       config: FitterConfig = FITTER) -> list[FaceObservation]:
    """Each image fitted as the first frame of a stream of the stack, as an observation.

    Parameters
    ----------
    model : FittingModel
    images : iterable of (H, W) or (H, W, 3) uint8 arrays
    config : FitterConfig
        The fitting the stack does (its appearance is sampled whatever it says).

    Returns
    -------
    list of FaceObservation
        Without landmarks (reason ``"no face"``) where Haar found none.
    """
    fitter = Fitter.from_config(model, replace(config, appearance=True, occlusion=False))
    tracker = Tracker(fitter, HaarFaceDetector(**defaults.DETECTOR))
    out = []
    for image in images:
        tracker.reset()
        result = tracker.track(image)
        if result is None:
            out.append(FaceObservation.from_arrays(image, None, None, True, "no face"))
        else:
            out.append(FaceObservation.from_arrays(image, result.points, appearance_of(result),
                                                   result.failed, result.reason))
    return out


def jaffe_faces(model_path: str | Path, folder: str | Path | None = None,
                config: FitterConfig = FITTER) -> JaffeFaces:
    """Every JAFFE image fitted by the model in ``model_path`` as ``config`` says, with its
    class and poser.

    Raises
    ------
    DatasetError
        When the folder holds no JAFFE image.
    """
    data = load_jaffe(folder)
    if not data.samples:
        raise DatasetError(f"no JAFFE image in {data.root}")
    images = progress((s.load_image() for s in data.samples), "fitting JAFFE",
                      len(data.samples))
    observations = stack_observations(FittingModel.load(model_path), images, config)
    names = np.array([s.image_path.name for s in data.samples])
    return JaffeFaces(observations, data.labels(), data.posers(), names)


def shape_template(observations: Sequence[FaceObservation], usable: np.ndarray) -> np.ndarray:
    """Mean canonical shape (68, 2) of the usable faces' landmarks."""
    shapes = [canonical_shape(observations[i].landmarks) for i in np.flatnonzero(usable)]
    if not shapes:
        raise ValueError("no usable face to make a shape template from")
    return np.mean(shapes, axis=0)


@dataclass
class DeployedModels:
    """What :func:`train_deployed` learns.

    Attributes
    ----------
    fitted : FittedFaceClassifier
        The variant's classifier (of relative vectors when the variant is relative).
    absolute : FittedFaceClassifier or None
        The person-independent linear model of absolute vectors (relative variants).
    temperature, absolute_temperature : float
        Their softmax temperatures, fitted on held-out posers.
    spec : PipelineSpec
    n_samples : int
        Faces trained on.
    """

    fitted: FittedFaceClassifier
    absolute: FittedFaceClassifier | None
    temperature: float
    absolute_temperature: float
    spec: PipelineSpec
    n_samples: int

    def classifier(self, fingerprint: str, info: Mapping[str, Any] | None = None
                   ) -> ExpressionClassifier:
        """The classifier file's contents for the fits of model ``fingerprint``."""
        notes = dict(info or {}) | {"samples": self.n_samples}
        return ExpressionClassifier.from_face_classifier(
            self.fitted, self.spec, fingerprint, notes, self.temperature, self.absolute,
            self.absolute_temperature)


def calibrated(X: np.ndarray, y: np.ndarray, groups: np.ndarray, dims: Mapping[str, int],
               variant: Variant) -> tuple[FittedFaceClassifier, float]:
    """``variant``'s classifier of X (n, d) and the temperature of its scores, fitted on
    held-out posers' faces, each scored by a classifier trained without them
    (:func:`~aamcore.expression.calibration.held_out_scores`)."""

    def fit(Xt: np.ndarray, yt: np.ndarray, gt: np.ndarray) -> Any:
        return fit_face_classifier(Xt, yt, gt, dims, variant.weights, variant.classifier).scores

    fitted = fit_face_classifier(X, y, groups, dims, variant.weights, variant.classifier)
    if len(np.unique(groups)) < 2:
        return fitted, 1.0
    scores = held_out_scores(fit, X, y, groups)
    truth = np.searchsorted(np.array(fitted.classes), y)
    return fitted, fit_temperature(scores, truth)


def train_deployed(
    faces: JaffeFaces,
    appearance_dim: int,
    variant: Variant = DEPLOYED,
    limits: QualityLimits = QualityLimits(),
    reference: Mapping[str, Any] = STREAM_REFERENCE,
    class_names: Sequence[str] = SEVEN_CLASSES,
    train: np.ndarray | None = None,
    neutral_reference: bool = False,
) -> DeployedModels:
    """Train ``variant`` on every classifiable face of ``faces`` (of ``train`` (n,) when given).

    The gate's shape template is the mean canonical shape of the faces the
    gate accepts; each face is taken relative to the median of its poser's
    classifiable faces (as in the benchmark); ``reference`` holds the stream
    settings the spec carries to the library and the service. A relative
    variant also gets the person-independent model of the absolute vectors.
    Both are calibrated on held-out posers. With ``neutral_reference`` each
    face's reference is the median of its poser's neutral faces instead, as a
    stream's is made of the frames called neutral.
    """
    config = variant.config()
    observed = observe(faces.observations, config, limits)
    ok = observed.ok & (True if train is None else np.asarray(train, bool))
    template = shape_template(faces.observations, ok)
    for i in np.flatnonzero(ok):
        ok[i] = not landmark_problem(faces.observations[i], limits, template)
    X = observed.vectors(variant.blocks)
    dims = observed.dims(variant.blocks)
    labels, posers = faces.labels.astype(str), faces.posers.astype(str)
    used = ok & np.isin(labels, list(class_names))
    absolute, absolute_t = None, 1.0
    with threadpool_limits(limits=1):
        if variant.relative:
            absolute, absolute_t = calibrated(X[used], labels[used], posers[used], dims, variant)
            usable = ok & (labels == NEUTRAL) if neutral_reference else ok
            X = X - poser_references(X, posers, usable)
        fitted, temperature = calibrated(X[used], labels[used], posers[used], dims, variant)
    spec = PipelineSpec(config, appearance_dim, variant.relative, dict(reference), limits,
                        template)
    return DeployedModels(fitted, absolute, temperature, absolute_t, spec, int(used.sum()))


def train_thesis(
    faces: JaffeFaces,
    appearance_dim: int,
    limits: QualityLimits = QualityLimits(),
    reference: Mapping[str, Any] = STREAM_REFERENCE,
    class_names: Sequence[str] = SEVEN_CLASSES,
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
    from aamcore.expression.evaluation import lda_mahalanobis_spec

    variant = variant_named(FEATURE_SETS["thesis"])
    config = variant.config()
    with_c = [o for o in faces.observations if o.appearance.size == appearance_dim]
    keep = np.array([o.appearance.size == appearance_dim for o in faces.observations])
    observed = observe(with_c, config, limits)
    ok = observed.ok
    template = shape_template(with_c, ok)
    for i in np.flatnonzero(ok):
        ok[i] = not landmark_problem(with_c[i], limits, template)
    X = observed.vectors(variant.blocks)
    labels, posers = faces.labels.astype(str)[keep], faces.posers.astype(str)[keep]
    train = ok & np.isin(labels, list(class_names))
    if not train.any():
        raise ValueError("no JAFFE face with an appearance passes the quality gate")
    def fit(Xt: np.ndarray, yt: np.ndarray, gt: np.ndarray) -> Any:
        return lda_mahalanobis_spec().fit(Xt, yt, gt).model_.scores

    with threadpool_limits(limits=1):
        estimator = lda_mahalanobis_spec().fit(X[train], labels[train], posers[train])
        scores = held_out_scores(fit, X[train], labels[train], posers[train])
    truth = np.searchsorted(np.array([str(c) for c in estimator.classes_]), labels[train])
    temperature = fit_temperature(scores, truth)
    spec = PipelineSpec(config, appearance_dim, False, dict(reference), limits, template)
    return estimator, spec, int(train.sum()), temperature


def train_classifier(model_path: str | Path, folder: str | Path | None = None,
                     algorithm: str = FITTER.algorithm, features: str = "deployed"
                     ) -> ExpressionClassifier:
    """The expression classifier of ``features`` (a key of :data:`FEATURE_SETS`) for the fits
    of ``model_path`` by ``algorithm``, trained on JAFFE."""
    if features not in FEATURE_SETS:
        raise ValueError(f"unknown expression features {features!r}: choose one of "
                         f"{list(FEATURE_SETS)}")
    # Every fit's landmarks and appearance are classified, failed ones too, so the failure
    # test (the default's) changes nothing the classifier learns.
    config = replace(FITTER, algorithm=algorithm)
    faces = jaffe_faces(model_path, folder, config)
    n_appearance = FittingModel.load(model_path).aam.n_appearance
    info = {"training": f"jaffe, {FEATURE_SETS[features]}", "training_version": TRAINING_VERSION,
            "model": Path(model_path).name, "algorithm": algorithm, "features": features,
            "failure_test": config.failure_test,
            "fit_failed": int(faces.fit_failed.sum()), "no_face": int(faces.no_face.sum())}
    fingerprint = model_fingerprint(model_path)
    with phase("classifier"):
        if features == "thesis":
            estimator, spec, n, temperature = train_thesis(faces, n_appearance)
            return ExpressionClassifier.from_estimator(estimator, fingerprint, spec,
                                                       info | {"samples": n}, temperature)
        return train_deployed(faces, n_appearance).classifier(fingerprint, info)


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
                    features: str = "deployed") -> Path:
    """The cached classifier of ``features`` for the fits of ``model_path`` by ``algorithm``,
    trained on first use; the file's name holds the three.

    Raises
    ------
    DatasetError
        When JAFFE is missing or none of its faces can be classified.
    """
    if features not in FEATURE_SETS:
        raise ValueError(f"unknown expression features {features!r}: choose one of "
                         f"{list(FEATURE_SETS)}")
    fingerprint = model_fingerprint(model_path)
    path = cache_dir() / f"expression-{fingerprint}-{algorithm}-{features}-v{TRAINING_VERSION}.npz"
    if not path.is_file():
        note(f"training the {features} expression classifier for the fits of "
             f"{Path(model_path).name} by {algorithm} on JAFFE, once: it is kept in "
             f"{path.parent}")
        path.parent.mkdir(parents=True, exist_ok=True)
        try:
            with plan("training the expression classifier", CLASSIFIER_PHASES):
                classifier = train_classifier(model_path, algorithm=algorithm, features=features)
        except ValueError as exc:  # no classifiable face: nothing to train on
            raise DatasetError(f"no expression classifier for {model_path}: {exc}") from exc
        tmp = path.with_name(f"{path.stem}.tmp{os.getpid()}.npz")
        classifier.save(tmp)
        tmp.replace(path)  # atomic: a concurrent first use never reads half a file
    return path
