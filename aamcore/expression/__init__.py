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

from aamcore.expression.analysis import analyse_face, face_problem
from aamcore.expression.classifier_file import (
    AAMMismatchError,
    ClassifierFileError,
    ExpressionClassifier,
)
from aamcore.expression.concentration import choose_n_components, concentration_study
from aamcore.expression.crop import FaceFeatureError, FaceObservation
from aamcore.expression.hypersphere import HypersphereMap
from aamcore.expression.labels import FIVE_CLASSES, SEVEN_CLASSES
from aamcore.expression.lda import FisherMahalanobis
from aamcore.expression.pipeline import ExpressionEstimate, ExpressionPipeline
from aamcore.expression.recogniser import ExpressionRecogniser, Recognition
from aamcore.expression.reference import NeutralReference
from aamcore.expression.spec import FeatureConfig, PipelineSpec, QualityLimits
from aamcore.expression.svm import SVMExpressionClassifier, tune_svm
from aamcore.expression.thesis_classifiers import ClassifierSpec, default_classifiers

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
