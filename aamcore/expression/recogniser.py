"""The expression of each tracked face, as the library and the expression service compute it.

:class:`ExpressionRecogniser` runs one stream's
:class:`~aamcore.expression.pipeline.ExpressionPipeline` on each fit and its
frame (quality gate, face features, the stream's reference, classifier) and,
when asked, averages the probabilities over the last few consecutive
classified frames (a frame without expression starts the average again) and
holds the label until another has led for a few frames (:class:`LabelHold`).
:class:`aamcore.tracker.FaceTracker` calls it with the frame it tracks, the
expression service with the frame its fit names, so the two give the same
expressions.
"""

from __future__ import annotations

import collections
from dataclasses import dataclass

import numpy as np

from aamcore import defaults
from aamcore.expression.classifier_file import ExpressionClassifier
from aamcore.expression.crop import SCHEME, FaceObservation
from aamcore.expression.pipeline import LOST_FRAMES_RESET, ExpressionPipeline


@dataclass(frozen=True, eq=False)
class Recognition:
    """An expression, or why there is none.

    Attributes
    ----------
    label : str or None
        The class of highest (smoothed) score; ``None``: no expression.
    class_names : tuple of str
    scores : (C,) float64 array or None
        Per-class probabilities (summing to 1) in ``class_names`` order; ``None``
        without a label.
    smoothed : bool
        Whether more than one frame went into the scores, or the label was held.
    reason : str
        Why there is no expression, ``"<key>: <details>"``; empty with a label.
    basis : str
        ``"relative"`` or ``"absolute"``: what decided
        (:class:`~aamcore.expression.pipeline.ExpressionEstimate`).
    """

    label: str | None
    class_names: tuple[str, ...]
    scores: np.ndarray | None
    smoothed: bool = False
    reason: str = ""
    basis: str = ""

    @property
    def ok(self) -> bool:
        return self.label is not None


class Smoother:
    """Mean of the last ``n`` score vectors, restarted after a gap in the frames given."""

    def __init__(self, n: int) -> None:
        if n < 1:
            raise ValueError(f"smoothing over {n} frames: it must be at least 1")
        self._scores: collections.deque[np.ndarray] = collections.deque(maxlen=n)
        self._last_index = -2

    def reset(self) -> None:
        self._scores.clear()

    def add(self, frame_index: int, scores: np.ndarray) -> tuple[np.ndarray, bool]:
        """The smoothed scores with this frame's, and whether more than one frame went in."""
        if frame_index != self._last_index + 1:
            self._scores.clear()
        self._last_index = frame_index
        self._scores.append(np.asarray(scores, np.float64))
        if len(self._scores) == 1:  # the mean of one: itself (np.mean's value, at less cost)
            return self._scores[0] / 1.0, False
        return np.mean(self._scores, axis=0), True


STACK_HOLD = defaults.EXPRESSION_HOLD
"""Classified frames a new label leads before it is shown, in the stack and the library
(:data:`aamcore.defaults.EXPRESSION_HOLD`)."""


class LabelHold:
    """Hysteresis on the label: a new label replaces the one shown only once it has led the
    (smoothed) probabilities for ``frames`` classified frames in a row; 0 holds nothing."""

    def __init__(self, frames: int) -> None:
        if frames < 0:
            raise ValueError(f"holding a label for {frames} frames: it must be at least 0")
        self.frames = frames
        self.reset()

    def reset(self) -> None:
        self.shown: int | None = None
        self._leader: int | None = None
        self._led = 0

    def add(self, scores: np.ndarray) -> int:
        """The column of the label shown after these scores (C,)."""
        best = int(np.argmax(scores))
        if self.frames == 0 or self.shown is None or best == self.shown:
            self.shown, self._leader, self._led = best, None, 0
            return best
        self._led = self._led + 1 if best == self._leader else 1
        self._leader = best
        if self._led >= self.frames:
            self.shown, self._leader, self._led = best, None, 0
        return self.shown


class ExpressionRecogniser:
    """Classify the faces of a stream, frame by frame, in frame order.

    Parameters
    ----------
    classifier : ExpressionClassifier
    smooth : int
        Classified frames averaged (1: none).
    lost_frames_reset : int
        Frames without a classifiable face after which the stream's reference
        is forgotten.
    hold : int
        Classified frames a new label must lead before it is shown (0: none; a
        frame without expression forgets the label shown).
    """

    def __init__(self, classifier: ExpressionClassifier, smooth: int = 1,
                 lost_frames_reset: int = LOST_FRAMES_RESET, hold: int = 0) -> None:
        self.classifier = classifier
        self._settings = (smooth, lost_frames_reset, hold)
        self.pipeline = ExpressionPipeline(classifier, lost_frames_reset)
        self.smoother = Smoother(smooth)
        self.hold = LabelHold(hold)
        self._last_index = -1

    def fresh(self) -> ExpressionRecogniser:
        """A recogniser of another face: the same classifier and settings, nothing seen."""
        smooth, lost, hold = self._settings
        return ExpressionRecogniser(self.classifier, smooth, lost, hold)

    def reset(self) -> None:
        """Forget the stream: its reference, the frames averaged and the label held."""
        self.pipeline.reset()
        self.smoother.reset()
        self.hold.reset()
        self._last_index = -1

    def recognise(
        self,
        frame_index: int,
        image: np.ndarray,
        landmarks: np.ndarray | None,
        appearance: np.ndarray | None,
        fit_failed: bool = False,
        fit_reason: str = "",
        scheme: str = SCHEME,
        occluded: np.ndarray | None = None,
    ) -> Recognition:
        """The expression of frame ``frame_index``.

        Parameters
        ----------
        frame_index : int
            A frame index that does not follow the last one given starts the
            stream afresh (a new run of the source).
        image : (H, W) or (H, W, 3) uint8 array
            The frame the fit was made on.
        landmarks : (N, 2) array or None
            The fit's landmarks in frame pixels; None or (0, 2) without a face.
        appearance : (k,) array or None
            The fit's appearance parameters ``c``.
        fit_failed, fit_reason
            The fitter's verdict (``"no face"`` when nothing was found).
        scheme : str
            The fit's landmark scheme.
        occluded : (N,) bool array, optional
            The fit's occlusion flags: a face covered beyond the gate's limit gets no label.

        Raises
        ------
        AAMMismatchError
            For a fit of another landmark scheme or appearance length than
            the classifier's.
        """
        if frame_index <= self._last_index:
            self.reset()
        self._last_index = frame_index
        if landmarks is not None and len(landmarks):
            n_appearance = 0 if appearance is None else int(np.size(appearance))
            self.classifier.check_fit(scheme, len(landmarks), n_appearance)
        observation = FaceObservation.from_arrays(image, landmarks, appearance, fit_failed,
                                                  fit_reason, occluded)
        estimate = self.pipeline.process(observation)
        names = self.classifier.class_names
        if estimate.scores is None:
            self.hold.reset()
            return Recognition(None, names, None, False, estimate.reason)
        scores, smoothed = self.smoother.add(frame_index, estimate.scores)
        shown = self.hold.add(scores)
        held = shown != int(np.argmax(scores))
        return Recognition(names[shown], names, scores, smoothed or held, "", estimate.basis)
