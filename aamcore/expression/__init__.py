"""Facial expression recognition from the fit and its frame (thesis part II, extended).

The pipeline (what the library and the expression service run per frame):

- :mod:`.crop`: :class:`FaceObservation` (frame, landmarks, ``c``) and the
  canonical, eye-aligned face frame;
- :mod:`.hog_patches`: HOG patches around the landmarks, mirror symmetry;
- :mod:`.quality`: the quality gate and its reasons;
- :mod:`.analysis`: gate and feature blocks of one face (:func:`analyse_face`);
- :mod:`.reference`: the stream's reference, a running median learned without labels;
- :mod:`.spec`: :class:`PipelineSpec`, the feature, reference and gate settings;
- :mod:`.face_classifier`: block-weighted linear models (logistic regression, shrinkage
  LDA) and the RBF SVM;
- :mod:`.scores`: the stored models' numpy predictors (no scikit-learn at serving);
- :mod:`.classifier_file`: :class:`ExpressionClassifier`, saved without pickle;
- :mod:`.pipeline`: :class:`ExpressionPipeline`, one stream;
- :mod:`.recogniser`: :class:`ExpressionRecogniser`, the pipeline with score smoothing.

Training: :mod:`.faces` (labelled faces as the stack fits them), :mod:`.learning` (the
person-independent and relative models and their fusion), :mod:`.training` (the
classifier of the model in use, cached). The thesis's classifiers:
:mod:`.thesis_classifiers`, :mod:`.lda` (Fisher LDA and Mahalanobis),
:mod:`.concentration` (eq 9.8), :mod:`.svm` with :mod:`.hypersphere`,
:mod:`.kernel_machines` and :mod:`.multiclass`. The benchmark lives in
:mod:`aamcore.evaluation` (``expression_*``).
"""

import importlib

from aamcore.expression.analysis import analyse_face, face_problem
from aamcore.expression.classifier_file import (
    AAMMismatchError,
    ClassifierFileError,
    ExpressionClassifier,
)
from aamcore.expression.crop import FaceFeatureError, FaceObservation
from aamcore.expression.labels import FIVE_CLASSES, SEVEN_CLASSES
from aamcore.expression.pipeline import ExpressionEstimate, ExpressionPipeline
from aamcore.expression.recogniser import ExpressionRecogniser, Recognition
from aamcore.expression.reference import NeutralReference
from aamcore.expression.spec import FeatureConfig, PipelineSpec, QualityLimits

_THESIS = {"choose_n_components": "concentration", "concentration_study": "concentration",
           "HypersphereMap": "hypersphere", "FisherMahalanobis": "lda",
           "SVMExpressionClassifier": "svm", "tune_svm": "svm",
           "ClassifierSpec": "thesis_classifiers", "default_classifiers": "thesis_classifiers"}
"""The thesis's classifiers by name and module: scikit-learn's estimators, imported when
first asked for, so that the pipeline starts without scikit-learn."""


def __getattr__(name: str) -> object:
    if name in _THESIS:
        return getattr(importlib.import_module(f"{__name__}.{_THESIS[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

__all__ = [
    "AAMMismatchError",
    "ClassifierFileError",
    "ClassifierSpec",
    "ExpressionClassifier",
    "ExpressionEstimate",
    "ExpressionPipeline",
    "ExpressionRecogniser",
    "FIVE_CLASSES",
    "FaceFeatureError",
    "FaceObservation",
    "FeatureConfig",
    "FisherMahalanobis",
    "HypersphereMap",
    "NeutralReference",
    "PipelineSpec",
    "QualityLimits",
    "Recognition",
    "SEVEN_CLASSES",
    "SVMExpressionClassifier",
    "analyse_face",
    "choose_n_components",
    "concentration_study",
    "default_classifiers",
    "face_problem",
    "tune_svm",
]
