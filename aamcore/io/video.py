"""Reading every frame of a video file."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np


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
