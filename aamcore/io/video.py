"""Reading every frame of a video file."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

FALLBACK_FPS = 30.0
"""The frame rate of a video that states none (or an impossible one)."""


def frame_rate(capture: cv2.VideoCapture) -> float:
    """The frame rate an opened capture states, or :data:`FALLBACK_FPS` when it states none
    from 1 to 1000."""
    fps = float(capture.get(cv2.CAP_PROP_FPS) or 0.0)
    return fps if 1.0 <= fps <= 1000.0 else FALLBACK_FPS


def video_facts(path: str | Path) -> tuple[int, float, tuple[int, int]]:
    """What a video file's container states: its frames (0 when it does not say; the frames
    read may be a few fewer), its frame rate (:func:`frame_rate`) and its size (width,
    height)."""
    capture = cv2.VideoCapture(str(path))
    try:
        return (max(int(capture.get(cv2.CAP_PROP_FRAME_COUNT) or 0), 0), frame_rate(capture),
                (int(capture.get(cv2.CAP_PROP_FRAME_WIDTH)),
                 int(capture.get(cv2.CAP_PROP_FRAME_HEIGHT))))
    finally:
        capture.release()


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
