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


MISSING_TOLERATED = 3
"""Frames a container may state beyond those that decode without the file being damaged
(``no_face.mp4`` states 98 and decodes 95: frames its edit list leaves out), or 1 % of them."""


def ended_early(read: int, stated: int) -> bool:
    """Whether a video file that states ``stated`` frames and gave ``read`` was cut short or
    is damaged: more frames missing than :data:`MISSING_TOLERATED` (or 1 %)."""
    return stated > 0 and stated - read > max(MISSING_TOLERATED, stated // 100)


def ended_early_problem(path: str | Path, read: int, stated: int) -> str:
    """One line naming a video file that :func:`ended_early` and the last frame read."""
    last = f"after frame {read - 1} ({read} of its {stated} frames" if read else (
        f"before its first frame (0 of its {stated} frames")
    return f"{path}: the video ended {last}: cut short or damaged?)"


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
