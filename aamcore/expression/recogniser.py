"""The expression of each tracked face, as the library and the expression service compute it.

:class:`ExpressionRecogniser` classifies a good fit with an
:class:`~aamcore.expression.classifier_file.ExpressionClassifier` and, when
asked, averages the scores over the last few consecutive frames (a gap in the
good fits starts the average again).
"""

from __future__ import annotations

import collections
from dataclasses import dataclass

import numpy as np

from aamcore.expression.classifier_file import ExpressionClassifier


@dataclass(frozen=True, eq=False)
class Recognition:
    """An expression.

    Attributes
    ----------
    label : str
        The class of highest (smoothed) score.
    class_names : tuple of str
    scores : (C,) float64 array
        Per-class scores in ``class_names`` order.
    smoothed : bool
        Whether more than one frame went into the scores.
    """

    label: str
    class_names: tuple[str, ...]
    scores: np.ndarray
    smoothed: bool


class Smoother:
    """Mean of the last ``n`` score vectors, restarted after a gap in good fits."""

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
        return np.mean(self._scores, axis=0), len(self._scores) > 1


class ExpressionRecogniser:
    """Classify the faces of a stream, frame by frame.

    Parameters
    ----------
    classifier : ExpressionClassifier
    smooth : int
        Frames averaged (1: none).
    """

    def __init__(self, classifier: ExpressionClassifier, smooth: int = 1) -> None:
        self.classifier = classifier
        self.smoother = Smoother(smooth)

    def reset(self) -> None:
        """Forget the frames seen: the next face starts a new average."""
        self.smoother.reset()

    def recognise(self, frame_index: int, appearance: np.ndarray) -> Recognition:
        """The expression of a good fit of frame ``frame_index`` with appearance ``c`` (k,).

        Raises
        ------
        ValueError
            For an appearance vector of another length, or a non-finite one.
        """
        _, scores = self.classifier.classify(np.asarray(appearance, np.float64))
        scores, smoothed = self.smoother.add(frame_index, scores)
        names = self.classifier.class_names
        return Recognition(names[int(np.argmax(scores))], names, scores, smoothed)
