"""The expression classifier for the AAM in use: trained on JAFFE on first use, then cached.

A classifier of appearance vectors ``c`` only makes sense for the AAM that
produced them, so the cached file is named after the AAM file's fingerprint
(a hash of its bytes) and records it (``ExpressionClassifier.aam_fingerprint``).
Training fits the AAM to every JAFFE face found by the Haar detector and
learns a one-against-all RBF SVM on the hypersphere (thesis chapter 10, C and
gamma chosen by cross-validation grouped by poser) on the fitted ``c``. On the
stack's LFPW AAM, leave-one-poser-out over JAFFE gave 59.9 % for this
classifier against 44.3 % for Fisher LDA + Mahalanobis (7 classes; the LDA
wins only on the per-fold JAFFE AAMs of ``aamtrack eval expression``).
"""

from __future__ import annotations

import hashlib
import logging
from pathlib import Path

import numpy as np

from aamcore.config import cache_dir
from aamcore.expression import ExpressionClassifier
from aamcore.expression.aam_features import fit_faces
from aamcore.expression.svm import tune_svm
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.io.jaffe import load_jaffe
from aamcore.io.sample import DatasetError
from aamcore.progress import note

log = logging.getLogger("aamtrack.expression")
TRAINING_VERSION = 3
"""Bump when the training below changes, so that cached classifiers are retrained."""
MIN_PER_CLASS = 5


def model_fingerprint(model_path: str | Path) -> str:
    """A short hash of an AAM model file's bytes."""
    digest = hashlib.sha256(Path(model_path).read_bytes()).hexdigest()
    return digest[:16]


def jaffe_appearance(
    model_path: str | Path, folder: str | Path | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fitted appearance vectors of the JAFFE faces (:func:`fit_faces`).

    Faces without a Haar detection or whose fit fails are left out.

    Returns
    -------
    X : (n, k) float64 array
        Appearance parameters ``c`` of each face.
    labels : (n,) array of str
        Its JAFFE class code.
    posers : (n,) array of str
    """
    data = load_jaffe(folder)
    faces = fit_faces(data.samples, Fitter(FittingModel.load(model_path), appearance=True))
    if not faces.samples:
        raise DatasetError(f"no JAFFE face could be fitted in {data.root}")
    return faces.appearance, data.labels()[faces.kept], data.posers()[faces.kept]


def train_classifier(model_path: str | Path, folder: str | Path | None = None) -> (
        ExpressionClassifier):
    """One-against-all SVM classifier of the AAM's appearance vectors on JAFFE."""
    X, y, posers = jaffe_appearance(model_path, folder)
    names, counts = np.unique(y, return_counts=True)
    keep = np.isin(y, names[counts >= MIN_PER_CLASS])
    estimator = tune_svm(X[keep], y[keep], posers[keep], "ova")
    info = {"training": "jaffe, AAM appearance c, RBF SVM one-against-all",
            "samples": int(keep.sum()), "training_version": TRAINING_VERSION,
            "model": Path(model_path).name}
    return ExpressionClassifier.from_estimator(estimator, model_fingerprint(model_path), info)


def classifier_path(model_path: str | Path) -> Path:
    """The cached classifier for the AAM in ``model_path``, trained on first use.

    Raises
    ------
    DatasetError
        When JAFFE is missing or no face of it could be fitted.
    """
    fingerprint = model_fingerprint(model_path)
    path = cache_dir() / f"expression-{fingerprint}-v{TRAINING_VERSION}.npz"
    if not path.is_file():
        note(f"training the expression classifier for {Path(model_path).name} on JAFFE, "
             f"once: it is kept in {path.parent}")
        path.parent.mkdir(parents=True, exist_ok=True)
        train_classifier(model_path).save(path)
    return path
