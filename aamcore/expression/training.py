"""The expression classifier for the fitting model in use: trained on JAFFE on first use, cached.

Landmarks and appearance vectors only make sense for the model that fitted
them, so the cached file is named after the model file's fingerprint (a hash
of its bytes) and records it (``ExpressionClassifier.aam_fingerprint``).

Training sees each JAFFE face as the stack sees a frame (:func:`stack_observations`):
a new stream, the Haar detector with the detector service's settings, the
fitter with the default algorithm and failure test, the landmarks and ``c``
at the precision of the ``Fit`` message. It then learns the deployed variant
(:data:`~aamcore.expression.variants.DEPLOYED`) on every face the quality
gate accepts (failed fits included: the fitter's appearance test rejects many
strongly expressive faces whose landmarks are right), each relative to the
median of its poser's faces (:func:`train_deployed`).
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from aamcore import defaults
from aamcore.config import cache_dir
from aamcore.detection.haar import HaarFaceDetector
from aamcore.expression.analysis import observe
from aamcore.expression.classifier_file import ExpressionClassifier
from aamcore.expression.crop import FaceObservation, canonical_shape
from aamcore.expression.face_classifier import FittedFaceClassifier, fit_face_classifier
from aamcore.expression.labels import SEVEN_CLASSES
from aamcore.expression.quality import landmark_problem
from aamcore.expression.reference import poser_references
from aamcore.expression.spec import STREAM_REFERENCE, PipelineSpec, QualityLimits
from aamcore.expression.variants import DEPLOYED, Variant
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.fitting.tracker import Tracker
from aamcore.io.jaffe import load_jaffe
from aamcore.io.sample import DatasetError
from aamcore.progress import note, progress

TRAINING_VERSION = 5
"""Bump when the training below changes, so that cached classifiers are retrained (3: the
RBF SVM of raw ``c``; 4 was the research branch's; 5: the face-feature pipeline)."""


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


def stack_observations(model: FittingModel, images: Iterable[np.ndarray]) -> list[FaceObservation]:
    """Each image fitted as the first frame of a stream of the stack, as an observation.

    Parameters
    ----------
    model : FittingModel
    images : iterable of (H, W) or (H, W, 3) uint8 arrays

    Returns
    -------
    list of FaceObservation
        Without landmarks (reason ``"no face"``) where Haar found none.
    """
    # The appearance c is sampled for the variants that classify it (the default method
    # computes none).
    fitter = Fitter(model, defaults.ALGORITHM, failure_test=defaults.FAILURE_TEST,
                    appearance=True)
    tracker = Tracker(fitter, HaarFaceDetector(**defaults.DETECTOR))
    out = []
    for image in images:
        tracker.reset()
        result = tracker.track(image)
        if result is None:
            out.append(FaceObservation.from_arrays(image, None, None, True, "no face"))
        else:
            out.append(FaceObservation.from_arrays(image, result.points, result.c,
                                                   result.failed, result.reason))
    return out


def jaffe_faces(model_path: str | Path, folder: str | Path | None = None) -> JaffeFaces:
    """Every JAFFE image fitted by the model in ``model_path``, with its class and poser.

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
    observations = stack_observations(FittingModel.load(model_path), images)
    names = np.array([s.image_path.name for s in data.samples])
    return JaffeFaces(observations, data.labels(), data.posers(), names)


def shape_template(observations: Sequence[FaceObservation], usable: np.ndarray) -> np.ndarray:
    """Mean canonical shape (68, 2) of the usable faces' landmarks."""
    shapes = [canonical_shape(observations[i].landmarks) for i in np.flatnonzero(usable)]
    if not shapes:
        raise ValueError("no usable face to make a shape template from")
    return np.mean(shapes, axis=0)


def train_deployed(
    faces: JaffeFaces,
    appearance_dim: int,
    variant: Variant = DEPLOYED,
    limits: QualityLimits = QualityLimits(),
    reference: Mapping[str, Any] = STREAM_REFERENCE,
    class_names: Sequence[str] = SEVEN_CLASSES,
) -> tuple[FittedFaceClassifier, PipelineSpec, int]:
    """Train ``variant`` on every classifiable face of ``faces``.

    The gate's shape template is the mean canonical shape of the faces the
    gate accepts; each face is taken relative to the median of its poser's
    classifiable faces (as in the benchmark); ``reference`` holds the stream
    settings the spec carries to the library and the service.

    Returns
    -------
    fitted : FittedFaceClassifier
    spec : PipelineSpec
    n_samples : int
        Faces trained on.
    """
    config = variant.config()
    observed = observe(faces.observations, config, limits)
    ok = observed.ok
    template = shape_template(faces.observations, ok)
    for i in np.flatnonzero(ok):
        ok[i] = not landmark_problem(faces.observations[i], limits, template)
    X = observed.vectors(variant.blocks)
    labels, posers = faces.labels.astype(str), faces.posers.astype(str)
    if variant.relative:
        X = X - poser_references(X, posers, ok)
    train = ok & np.isin(labels, list(class_names))
    with threadpool_limits(limits=1):
        fitted = fit_face_classifier(X[train], labels[train], posers[train],
                                     observed.dims(variant.blocks), variant.weights,
                                     variant.classifier)
    spec = PipelineSpec(config, appearance_dim, variant.relative, dict(reference), limits,
                        template)
    return fitted, spec, int(train.sum())


def train_classifier(model_path: str | Path, folder: str | Path | None = None
                     ) -> ExpressionClassifier:
    """The deployed expression classifier of the fits of ``model_path``, trained on JAFFE."""
    faces = jaffe_faces(model_path, folder)
    n_appearance = FittingModel.load(model_path).aam.n_appearance
    fitted, spec, n = train_deployed(faces, n_appearance)
    info = {"training": f"jaffe, {DEPLOYED.name}", "samples": n,
            "training_version": TRAINING_VERSION, "model": Path(model_path).name,
            "algorithm": defaults.ALGORITHM, "failure_test": defaults.FAILURE_TEST,
            "fit_failed": int(faces.fit_failed.sum()), "no_face": int(faces.no_face.sum())}
    return ExpressionClassifier.from_face_classifier(fitted, spec, model_fingerprint(model_path),
                                                     info)


def classifier_path(model_path: str | Path) -> Path:
    """The cached classifier for the model in ``model_path``, trained on first use.

    Raises
    ------
    DatasetError
        When JAFFE is missing or none of its faces can be classified.
    """
    fingerprint = model_fingerprint(model_path)
    path = cache_dir() / f"expression-{fingerprint}-v{TRAINING_VERSION}.npz"
    if not path.is_file():
        note(f"training the expression classifier for {Path(model_path).name} on JAFFE, "
             f"once: it is kept in {path.parent}")
        path.parent.mkdir(parents=True, exist_ok=True)
        try:
            classifier = train_classifier(model_path)
        except ValueError as exc:  # no classifiable face: nothing to train on
            raise DatasetError(f"no expression classifier for {model_path}: {exc}") from exc
        tmp = path.with_name(f"{path.stem}.tmp{os.getpid()}.npz")
        classifier.save(tmp)
        tmp.replace(path)  # atomic: a concurrent first use never reads half a file
    return path
