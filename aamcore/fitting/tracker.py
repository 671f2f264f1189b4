"""Tracking a face from frame to frame, re-detecting when there is none or a fit fails."""

from __future__ import annotations

from typing import Protocol

import numpy as np

from aamcore.detection.haar import HaarFaceDetector
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.result import FitResult


class FaceDetector(Protocol):
    """Anything that finds face boxes: ``detect(image) -> (K, 4)`` ``x, y, w, h``, largest first."""

    def detect(self, image: np.ndarray) -> np.ndarray: ...


class Tracker:
    """Track a face from frame to frame, re-detecting when there is none or a fit fails.

    Parameters
    ----------
    fitter : Fitter
    detector : FaceDetector, optional
        Haar by default.
    """

    def __init__(self, fitter: Fitter, detector: FaceDetector | None = None) -> None:
        self.fitter = fitter
        self.detector = detector or HaarFaceDetector()
        self.last: FitResult | None = None
        self.size: tuple[int, ...] = ()
        self.detections = 0

    def reset(self) -> None:
        """Forget the last fit: the next frame starts from a detection."""
        self.last = None

    def track(self, image: np.ndarray) -> FitResult | None:
        """Fit ``image``; None when no face is found.

        A failed fit from the previous frame's parameters triggers a
        detection on the same frame (thesis section 7.2.2); so does a frame of
        another size than the last (the last fit says nothing of it). A failed
        fit from a detection is returned but not tracked from: the next frame
        detects again.

        Raises
        ------
        ValueError
            For something that is not an image array.
        """
        if not isinstance(image, np.ndarray) or image.ndim not in (2, 3) or image.size == 0:
            raise ValueError(f"not an image: {type(image).__name__} "
                             f"{getattr(image, 'shape', '')}")
        if image.shape[:2] != self.size:
            self.size = image.shape[:2]
            self.last = None
        if self.last is not None:
            result = self.fitter.track(image, self.last)
            if result.ok:
                self.last = result
                return result
        self.detections += 1
        boxes = self.detector.detect(image)
        if len(boxes) == 0:
            self.last = None
            return None
        result = self.fitter.fit_box(image, boxes[0])
        self.last = result if result.ok else None
        return result
