"""Opening a video input (file, camera or stream URL) through OpenCV, with clear errors.

:class:`VideoInput` checks what it is given before OpenCV sees it (a missing
file, an empty one, a file that does not decode, a URL that does not answer
within a timeout) and raises :class:`SourceError` naming the input and the
problem. :class:`VideoInput` then yields ``(H, W, 3)`` BGR frames, replaying a
file ``loops`` times.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from aamcore.io.video import ended_early, ended_early_problem, frame_rate
from proto.limits import MAX_IMAGE_HEIGHT, MAX_IMAGE_PIXELS, MAX_IMAGE_WIDTH
from services.source.options import URL_PREFIXES, SourceOptions

OPEN_TIMEOUT_MS = 5000
"""How long a stream URL may take to answer when opened or read."""


class SourceError(RuntimeError):
    """A video input cannot be opened or read; the message names it and says why."""


@dataclass(frozen=True)
class InputSpec:
    """What to capture from: exactly one of a file, a camera index or a URL."""

    video: str | None = None
    camera: int | None = None
    url: str | None = None

    def __post_init__(self) -> None:
        given = [x is not None for x in (self.video, self.camera, self.url)]
        if sum(given) != 1:
            raise ValueError("give exactly one of a video file, a camera index or a stream URL")
        if self.url is not None and not self.url.startswith(URL_PREFIXES):
            raise ValueError(f"stream URL {self.url!r} does not start with one of {URL_PREFIXES}")

    @classmethod
    def of(cls, options: SourceOptions) -> InputSpec:
        """The input ``options`` name."""
        return cls(options.video, options.camera, options.url)

    @property
    def is_file(self) -> bool:
        return self.video is not None

    def describe(self) -> str:
        if self.video is not None:
            return f"video file {self.video}"
        if self.camera is not None:
            return f"camera {self.camera}"
        return f"stream {self.url}"


def _open_capture(spec: InputSpec) -> cv2.VideoCapture:
    if spec.video is not None:
        path = Path(spec.video)
        if not path.exists():
            raise SourceError(f"{spec.describe()}: no such file")
        if path.is_dir():
            raise SourceError(f"{spec.describe()}: is a folder, not a video file")
        if not path.is_file():
            raise SourceError(f"{spec.describe()}: not a regular file")
        if path.stat().st_size == 0:
            raise SourceError(f"{spec.describe()}: the file is empty")
        return cv2.VideoCapture(str(path))
    if spec.camera is not None:
        # On Linux a camera is a V4L2 device: its absence is told without OpenCV's warnings.
        if sys.platform.startswith("linux") and not Path(f"/dev/video{spec.camera}").exists():
            raise SourceError(f"{spec.describe()}: no such camera (/dev/video{spec.camera} "
                              "does not exist)")
        return cv2.VideoCapture(spec.camera)
    params = [cv2.CAP_PROP_OPEN_TIMEOUT_MSEC, OPEN_TIMEOUT_MS,
              cv2.CAP_PROP_READ_TIMEOUT_MSEC, OPEN_TIMEOUT_MS]
    return cv2.VideoCapture(spec.url, cv2.CAP_FFMPEG, params)


class VideoInput:
    """An opened video input; iterate :meth:`frames` for BGR frames.

    Parameters
    ----------
    spec : InputSpec
    loops : int
        Times to play a file (0: forever); ignored for cameras and URLs.

    Raises
    ------
    SourceError
        When the input cannot be opened or its first frame cannot be read.
    """

    def __init__(self, spec: InputSpec, loops: int = 1) -> None:
        if loops < 0:
            raise ValueError(f"loops must be >= 0, got {loops}")
        self.spec = spec
        self.loops = loops if spec.is_file else 1
        self._cap = _open_capture(spec)
        if not self._cap.isOpened():
            self._cap.release()
            why = ("not a video OpenCV can decode" if spec.is_file else
                   "a camera that is absent or busy" if spec.camera is not None else
                   f"no answer within {OPEN_TIMEOUT_MS / 1000:g} s, or not a video stream")
            raise SourceError(f"{spec.describe()}: OpenCV cannot open it ({why})")
        ok, first = self._cap.read()
        if not ok or first is None or first.size == 0:
            self._cap.release()
            raise SourceError(f"{spec.describe()}: opened but no frame could be read "
                              "(corrupt or empty video)")
        self._first: np.ndarray | None = first
        self.height, self.width = first.shape[:2]
        problem = frame_size_problem(self.width, self.height)
        if problem:
            self._cap.release()
            raise SourceError(f"{spec.describe()}: {problem}")
        self.fps = frame_rate(self._cap)
        self.read_errors = 0
        self.stated = max(int(self._cap.get(cv2.CAP_PROP_FRAME_COUNT) or 0), 0)
        """The frames a file's container states (0 for a camera or a stream)."""
        self.damaged = ""
        """Why a file's frames ended early (:func:`~aamcore.io.video.ended_early`): one
        line naming it and the last frame read, once :meth:`frames` has stopped there."""

    def frames(self, in_place: bool = False) -> Iterator[np.ndarray]:
        """Frames in order, every pass of a file; stops at the end or on a read error, and
        at the end of a pass of a file that ended early (:attr:`damaged` says so).

        ``in_place``: each frame is decoded into the same buffer (:func:`pixel_buffer`),
        valid until the next is asked for: what a producer that sends it at once needs.
        """
        played = 0
        buffer = pixel_buffer((self.height, self.width, 3)) if in_place else None
        while True:
            frame = self._take_first() if played == 0 else None
            read = 0
            if frame is not None:
                read += 1
                if buffer is not None and frame.shape == buffer.shape:
                    buffer[...] = frame
                    frame = buffer
                yield frame
            while True:
                ok, frame = self._cap.read(buffer) if buffer is not None else self._cap.read()
                if not ok or frame is None:
                    break
                read += 1
                yield frame
            if self.spec.is_file and ended_early(read, self.stated):
                self.damaged = ended_early_problem(self.spec.video, read, self.stated)
                return
            played += 1
            if self.loops != 0 and played >= self.loops:
                return
            if not self._cap.set(cv2.CAP_PROP_POS_FRAMES, 0):
                raise SourceError(f"{self.spec.describe()}: cannot rewind to loop")

    def _take_first(self) -> np.ndarray | None:
        first, self._first = self._first, None
        return first

    def close(self) -> None:
        """Release the capture."""
        self._cap.release()

    def __enter__(self) -> VideoInput:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def pixel_buffer(shape: tuple[int, ...]) -> np.ndarray:
    """A ``uint8`` array of ``shape`` over a ``bytearray``: the pixels decoded into it can be
    copied as they are into a shared-memory buffer (which takes only bytes-like Python
    objects, :mod:`services.bus.shm`)."""
    size = 1
    for side in shape:
        size *= side
    return np.frombuffer(bytearray(size), np.uint8).reshape(shape)


def frame_size_problem(width: int, height: int) -> str:
    """Why frames of ``width`` x ``height`` cannot go on the bus, or ``""``."""
    if width > MAX_IMAGE_WIDTH or height > MAX_IMAGE_HEIGHT or width * height > MAX_IMAGE_PIXELS:
        return (f"frames of {width} x {height} exceed the frame limit ({MAX_IMAGE_WIDTH} px a "
                f"side, {MAX_IMAGE_WIDTH} x {MAX_IMAGE_PIXELS // MAX_IMAGE_WIDTH} in all): "
                "scale the video down first")
    return ""
