"""Writing an annotated video: the containers OpenCV's wheel writes, checked before a run."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

if TYPE_CHECKING:
    from aamcore.face_result import FaceResult

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


class AnnotatedVideo:
    """Frames with their results drawn on them (:class:`~aamcore.annotate.Annotator`), written
    to ``path`` by a thread of its own, so that drawing and encoding a frame overlap with
    tracking the next (OpenCV and the GL driver work outside the GIL).

    ``put(frame, faces, K)`` queues a frame (waiting while ``backlog`` frames are queued);
    ``close()`` writes the rest and returns the frames written. An error of the thread (a file
    OpenCV cannot write) is raised by the next ``put`` or by ``close``.
    """

    def __init__(self, path: str | Path, fps: float, glasses: bool = True,
                 backlog: int = 8) -> None:
        import queue
        import threading

        self.writer = VideoWriter(path, fps)
        self.glasses = glasses
        self.glasses_problem = ""
        self._queue: queue.Queue = queue.Queue(backlog)
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="annotate", daemon=True)
        self._thread.start()

    def put(self, frame: np.ndarray, faces: Sequence[FaceResult], K: np.ndarray | None
            ) -> None:
        self._raise()
        self._queue.put((frame, faces, K))

    def close(self) -> int:
        """Write what is queued, close the file; the frames written."""
        if self._thread.is_alive():
            self._queue.put(None)
            self._thread.join()
        self._raise()
        return self.writer.frames

    def _raise(self) -> None:
        if self._error is not None:
            error, self._error = self._error, None
            raise error

    def _run(self) -> None:
        from aamcore.annotate.annotator import Annotator

        with Annotator(self.glasses) as annotator, self.writer:  # GL: this thread's context
            while (item := self._queue.get()) is not None:
                if self._error is not None:
                    continue  # drain: the producer hears of the error at its next put
                try:
                    self.writer.write(annotator.draw(*item))
                except Exception as exc:  # handed to the producer
                    self._error = exc
                self.glasses_problem = annotator.glasses_problem
