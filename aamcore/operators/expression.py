"""The expression stage: the expression of every face of a frame, from its fit and the frame,
each face with its own recogniser (its reference, averaging and label hold)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from aamcore.expression.classifier_file import ExpressionClassifier
from aamcore.expression.recogniser import ExpressionRecogniser, Recognition
from aamcore.operators.faces import FaceFit, FrameRef
from aamcore.operators.options import PIPELINE, ExpressionOptions
from aamcore.operators.per_face import FORGET_FRAMES, PerFace


class ExpressionOperator:
    """Expressions of a frame's fits (:class:`~aamcore.expression.recogniser.ExpressionRecogniser`
    per face).

    Parameters
    ----------
    classifier : ExpressionClassifier
    options : ExpressionOptions
    forget_frames : int
        The fit stage's :attr:`~aamcore.fitting.config.NewFaces.forget_frames`.
    """

    def __init__(self, classifier: ExpressionClassifier,
                 options: ExpressionOptions = PIPELINE.expression,
                 forget_frames: int = FORGET_FRAMES) -> None:
        self.options = options
        self.classifier = classifier
        first = ExpressionRecogniser(classifier, options.average, options.reference_reset,
                                     hold=options.hold)
        self.faces = PerFace(first.fresh, ExpressionRecogniser.reset, first, forget_frames)

    @property
    def class_names(self) -> tuple[str, ...]:
        return tuple(self.classifier.class_names)

    def __call__(self, frame: FrameRef, image: np.ndarray, faces: Sequence[FaceFit]
                 ) -> list[Recognition]:
        """The expression of each face of ``image`` (the frame the fits were made on), or why
        there is none.

        Raises
        ------
        AAMMismatchError
            For a fit of another landmark scheme or appearance length than the classifier's.
        """
        return [self._recognise(frame, image, face) for face in faces]

    def _recognise(self, frame: FrameRef, image: np.ndarray, face: FaceFit) -> Recognition:
        recogniser = self.faces.of(face.face_id, frame.index)
        return recogniser.recognise(frame.index, image, face.points if face.found else None,
                                    face.appearance, face.failed, face.reason, face.scheme,
                                    face.occluded)

    def reset(self) -> None:
        """Forget every face (a new run)."""
        self.faces.clear()


def load_classifier(classifier: str | Path | ExpressionClassifier, model: str | Path | None = None,
                    algorithm: str | None = None) -> ExpressionClassifier:
    """The classifier of file ``classifier`` (or the one given), refused when it was made for
    the fits of another fitting model than the file ``model`` (fingerprint), or of another
    algorithm than ``algorithm`` (when given).

    Raises
    ------
    ClassifierFileError, AAMMismatchError, OSError
        For a file that cannot be read or is of another format or feature version, or a
        classifier made for other fits.
    """
    from aamcore.expression.training import check_made_for, model_fingerprint

    if not isinstance(classifier, ExpressionClassifier):
        classifier = ExpressionClassifier.load(classifier)
    if model and algorithm:
        check_made_for(classifier, model_fingerprint(model), algorithm)
    elif model:
        classifier.check_aam(model_fingerprint(model))
    return classifier
