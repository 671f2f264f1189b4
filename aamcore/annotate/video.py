"""Writing an annotated video: the containers OpenCV's wheel writes, checked before a run."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

CODECS = {".mp4": "mp4v", ".avi": "MJPG"}
"""The video files an annotated video can be, by suffix, and their codec (OpenCV's wheel
writes no H.264)."""


def video_output_problem(path: str | Path) -> str:
    """Why an annotated video cannot be written at ``path`` ("" when it can be tried)."""
    suffix = Path(path).suffix.lower()
    if suffix not in CODECS:
        return f"{path}: write a {' or '.join(CODECS)} file (not {suffix or 'no suffix'})"
    return ""


class VideoWriter:
    """Frames to a video file at ``fps``, opened at the first frame (its size is the video's).

    Raises
    ------
    OSError
        When OpenCV cannot open the file for writing.
    """

    def __init__(self, path: str | Path, fps: float) -> None:
        if problem := video_output_problem(path):
            raise ValueError(problem)
        self.path = Path(path)
        self.fps = fps
        self.frames = 0
        self._writer: cv2.VideoWriter | None = None

    def write(self, image: np.ndarray) -> None:
        if self._writer is None:
            height, width = image.shape[:2]
            codec = cv2.VideoWriter_fourcc(*CODECS[self.path.suffix.lower()])
            self._writer = cv2.VideoWriter(str(self.path), codec, self.fps, (width, height))
            if not self._writer.isOpened():
                raise OSError(f"{self.path}: OpenCV cannot write a video here")
        self._writer.write(image)
        self.frames += 1

    def close(self) -> None:
        if self._writer is not None:
            self._writer.release()
            self._writer = None

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
