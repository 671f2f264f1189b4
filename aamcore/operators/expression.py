"""The expression stage: the expression of every face of a frame, from its fit and the frame,
each face with its own recogniser (its reference, averaging and label hold)."""

from __future__ import annotations

from collections.abc import Sequence

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
