"""Head pose end to end: landmarks from a tracker on rendered or recorded frames."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import cv2
import numpy as np

from aamcore.fitting.fitter import Tracker


def track_frames(
    frames: Iterable[np.ndarray], tracker: Tracker
) -> tuple[list[np.ndarray | None], int]:
    """Track every frame; landmarks (N, 2) per frame, None where there was no good fit.

    Returns
    -------
    landmarks : list
    flagged : int
        Fits left out because they failed the test of eq. 7.2.
    """
    tracker.reset()
    landmarks: list[np.ndarray | None] = []
    flagged = 0
    for frame in frames:
        fit = tracker.track(frame)
        if fit is not None and fit.failed:
            flagged += 1
        landmarks.append(None if fit is None or fit.failed else fit.points)
    return landmarks, flagged


def video_frames(path: str | Path) -> list[np.ndarray]:
    """Every frame of a video file, BGR.

    Raises
    ------
    OSError
        If the file cannot be opened or holds no frame.
    """
    capture = cv2.VideoCapture(str(path))
    frames = []
    try:
        while True:
            ok, frame = capture.read()
            if not ok:
                break
            frames.append(frame)
    finally:
        capture.release()
    if not frames:
        raise OSError(f"{path}: no readable video frames")
    return frames
