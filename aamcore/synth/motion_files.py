"""A generated motion sequence on disk: a video any OpenCV reader opens, and its ground truth.

The video is FFV1 in AVI, lossless, so a tracker reading it back (``aamtrack
run --video``, :meth:`aamcore.tracker.FaceTracker.process_video`) sees exactly
the frames that were generated and a benchmark measures the tracker, not the
compression. The ground truth beside it (``truth.npz``) holds the landmarks of
every frame, the occluded flags, the frame rate and the :class:`MotionSpec`
the sequence was made with. It is written last, so a folder with a ground
truth holds a complete sequence.
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass
from pathlib import Path

import cv2
import numpy as np

from aamcore.synth.motion import SIZE, MotionSpec, Sequence

VIDEO_NAME = "video.avi"
TRUTH_NAME = "truth.npz"
FOURCC = "FFV1"
"""Lossless, and read back by OpenCV's FFmpeg backend frame for frame."""


@dataclass(frozen=True)
class SequenceFiles:
    """Where a sequence was written.

    Attributes
    ----------
    video : Path
    truth : Path
    """

    video: Path
    truth: Path


@dataclass(frozen=True)
class GroundTruth:
    """The ground truth of a written sequence.

    Attributes
    ----------
    landmarks : (F, N, 2) float64 array
        The exact landmarks of every frame, pixels.
    occluded : (F,) bool array
        Frames where the occluder covers part of the face.
    fps : float
    spec : MotionSpec or None
        How the sequence moves, when it was written with one.
    covered : (F, N) float array
        Per frame and landmark, the share of its part of the face the occluder covers
        (:attr:`aamcore.synth.motion.Sequence.covered`; zeros for a sequence written
        without it).
    """

    landmarks: np.ndarray
    occluded: np.ndarray
    fps: float
    spec: MotionSpec | None
    covered: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.covered is None:
            object.__setattr__(self, "covered", np.zeros(self.landmarks.shape[:2]))

    @property
    def frames(self) -> int:
        return len(self.landmarks)


def write_sequence(sequence: Sequence, folder: str | Path, fps: float = 30.0,
                   spec: MotionSpec | None = None) -> SequenceFiles:
    """Write ``sequence`` as ``video.avi`` (FFV1) and ``truth.npz`` into ``folder``.

    Parameters
    ----------
    sequence : Sequence
        Frames (360, 640, 3) uint8, landmarks (F, N, 2), occluded flags (F,).
    folder : path
        Created if needed; a sequence already there is replaced.
    fps : float
        Frame rate written into the video.
    spec : MotionSpec, optional
        Stored with the ground truth.

    Raises
    ------
    OSError
        When OpenCV cannot write the video.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    files = SequenceFiles(folder / VIDEO_NAME, folder / TRUTH_NAME)
    files.truth.unlink(missing_ok=True)
    writer = cv2.VideoWriter(str(files.video), cv2.VideoWriter_fourcc(*FOURCC), fps, SIZE)
    if not writer.isOpened():
        raise OSError(f"{files.video}: OpenCV cannot write {FOURCC} video")
    for frame in sequence.frames:
        writer.write(frame)
    writer.release()
    meta = json.dumps(None if spec is None else asdict(spec))
    partial = folder / f".{TRUTH_NAME}.part.npz"
    np.savez(partial, landmarks=sequence.landmarks, occluded=sequence.occluded,
             covered=sequence.covered, fps=np.float64(fps), spec=np.array(meta))
    os.replace(partial, files.truth)
    return files


def _spec(meta: str) -> MotionSpec | None:
    fields = json.loads(meta)
    if fields is None:
        return None
    for key in ("scales", "occluder"):
        if fields.get(key) is not None:
            fields[key] = tuple(fields[key])
    return MotionSpec(**fields)


def read_ground_truth(folder: str | Path) -> GroundTruth:
    """The ground truth that :func:`write_sequence` wrote into ``folder``.

    Raises
    ------
    FileNotFoundError
        When the folder holds no (complete) sequence.
    """
    path = Path(folder) / TRUTH_NAME
    with np.load(path) as data:
        covered = np.array(data["covered"], np.float64) if "covered" in data.files else None
        return GroundTruth(np.array(data["landmarks"], np.float64),
                           np.array(data["occluded"], bool), float(data["fps"]),
                           _spec(str(data["spec"])), covered)


def video_path(folder: str | Path) -> Path:
    """The video file of the sequence in ``folder``."""
    return Path(folder) / VIDEO_NAME
