"""Facial expression recognition from appearance vectors (thesis part II).

- :mod:`.lda`: Fisher LDA projection and Mahalanobis classification.
- :mod:`.concentration`: the k-means metric choosing the Fisher directions kept.
- :mod:`.svm`: RBF SVMs on the unit hypersphere, one-against-all, one-against-one
  and decision DAG, tuned by cross-validation split by poser.
- :mod:`.classifier_file`: :class:`ExpressionClassifier`, saved without pickle.
- :mod:`.evaluation`: leave-one-poser-out evaluation with per-fold features.
- :mod:`.features`: the pixel PCA baseline features.
- :mod:`.report`: confusion matrices as text and PNG.
- :mod:`.benchmark`: the JAFFE benchmark.
"""

from aamcore.expression.classifier_file import (
    AAMMismatchError,
    ClassifierFileError,
    ExpressionClassifier,
)
from aamcore.expression.concentration import choose_n_components, concentration_study
from aamcore.expression.evaluation import (
    ClassifierSpec,
    EvaluationResult,
    FoldFeatures,
    GivenFeatures,
    default_classifiers,
    leave_one_poser_out,
)
from aamcore.expression.features import PixelPCAFeatures, crop_faces
from aamcore.expression.hypersphere import HypersphereMap
from aamcore.expression.labels import FIVE_CLASSES, SEVEN_CLASSES
from aamcore.expression.lda import FisherMahalanobis
from aamcore.expression.svm import SVMExpressionClassifier, tune_svm

__all__ = [
    "AAMMismatchError",
    "ClassifierFileError",
    "ClassifierSpec",
    "EvaluationResult",
    "ExpressionClassifier",
    "FIVE_CLASSES",
    "FisherMahalanobis",
    "FoldFeatures",
    "GivenFeatures",
    "HypersphereMap",
    "PixelPCAFeatures",
    "SEVEN_CLASSES",
    "SVMExpressionClassifier",
    "choose_n_components",
    "concentration_study",
    "crop_faces",
    "default_classifiers",
    "leave_one_poser_out",
    "tune_svm",
]
