"""The detect stage: the boxes of the faces in a frame (Haar, :mod:`aamcore.detection.haar`)."""

from __future__ import annotations

import numpy as np

from aamcore.detection.haar import HaarFaceDetector
from aamcore.operators.options import PIPELINE, DetectOptions


class DetectOperator:
    """Face boxes of a frame, largest first.

    Parameters
    ----------
    options : DetectOptions

    Raises
    ------
    FileNotFoundError, RuntimeError, ValueError
        When the cascade cannot be loaded, or for settings it refuses.
    """

    def __init__(self, options: DetectOptions = PIPELINE.detect) -> None:
        self.options = options
        self.detector = HaarFaceDetector(scale_factor=options.scale_factor,
                                         min_neighbors=options.min_neighbors,
                                         min_size=(options.min_size, options.min_size),
                                         max_side=options.max_side or None)

    def __call__(self, image: np.ndarray) -> np.ndarray:
        """The boxes ``(K, 4)`` ``x, y, w, h`` of the faces in ``image`` (BGR or grey)."""
        return self.detector.detect(image)

    def detect(self, image: np.ndarray) -> np.ndarray:
        """As calling it: the fit stage's :class:`~aamcore.fitting.tracker.FaceDetector`."""
        return self.detector.detect(image)

    def __repr__(self) -> str:
        return repr(self.detector)

    def settings(self) -> dict:
        """The search's settings (what a fitter detecting in its place should use)."""
        return self.detector.settings()
