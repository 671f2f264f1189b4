"""What a fitting model trains on: the training faces of one or more sets, their detections.

``lfpw``, ``helen`` and ``afw`` give their training split only
(:mod:`aamcore.io.splits`: the held-out photos never enter a model); any other
folder gives all its faces. Images are read and searched by the detector once,
in threads, and kept grey and shrunk for the local-binary training.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aamcore.config import data_root, resolve_dataset
from aamcore.detection.boxes import match_detection
from aamcore.detection.haar import HaarFaceDetector
from aamcore.fitting.training.faces import shrink_face
from aamcore.io import FaceSample, load_annotated_folder
from aamcore.io.landmarks import LandmarkScheme
from aamcore.io.splits import set_name_of, split
from aamcore.io.video import video_frames


@dataclass(frozen=True)
class TrainingSet:
    """The training faces of one or more folders.

    Attributes
    ----------
    samples : list of FaceSample
    scheme : LandmarkScheme
        Their markup (the same for every folder).
    folders : list of Path
    split : list of bool
        Whether each folder gave its training split only.
    errors : list of str
        One message per file that could not be read (left out).
    """

    samples: list[FaceSample]
    scheme: LandmarkScheme
    folders: list[Path]
    split: list[bool]
    errors: list[str]

    @property
    def name(self) -> str:
        """The folders' names joined by ``-`` (``lfpw/trainset`` is ``lfpw``)."""
        return "-".join(f.parent.name if f.name == "trainset" else f.name for f in self.folders)


def dataset_names(dataset: str | Sequence[str]) -> list[str]:
    """The names or folders of a comma-separated ``dataset`` (or a sequence of them)."""
    parts = dataset.split(",") if isinstance(dataset, str) else list(dataset)
    names = [str(p).strip() for p in parts if str(p).strip()]
    if not names:
        raise ValueError(f"no dataset named in {dataset!r}")
    return names


def training_set(dataset: str | Sequence[str], limit: int | None = None) -> TrainingSet:
    """The training faces of ``dataset`` (comma-separated names or folders).

    ``limit`` keeps the first ``ceil(limit / number of folders)`` faces of each
    (small models for tests).

    Raises
    ------
    ValueError
        When the folders use different markups.
    FileNotFoundError, DatasetError
        For a missing or unreadable folder.
    """
    folders = [resolve_dataset(name) for name in dataset_names(dataset)]
    per = math.ceil(limit / len(folders)) if limit else None
    samples: list[FaceSample] = []
    scheme: LandmarkScheme | None = None
    split_used, errors = [], []
    for folder in folders:
        data = load_annotated_folder(folder)
        errors += data.errors
        try:
            chosen, _ = split(data.samples, set_name_of(folder))
            split_used.append(True)
        except ValueError:
            chosen = data.samples
            split_used.append(False)
        if scheme is not None and data.scheme.n_points != scheme.n_points:
            raise ValueError(f"{folder}: {data.scheme.name} markup, the other folders have "
                             f"{scheme.name}: a model is trained on one markup")
        scheme = scheme or data.scheme
        samples += chosen[:per] if per else chosen
    assert scheme is not None
    return TrainingSet(samples, scheme, folders, split_used, errors)


@dataclass(frozen=True)
class DetectedFace:
    """One training image, read once: grey and shrunk, with its matched detection.

    Attributes
    ----------
    grey : (H, W) uint8 array
        Shrunk by ``factor`` (:func:`~aamcore.fitting.training.faces.shrink_face`).
    factor : float
    boxes : (K, 4) array
        Every detection in the original image's pixels.
    box : (4,) array or None
        The detection matched to the face, None where the detector missed it.
    """

    grey: np.ndarray
    factor: float
    boxes: np.ndarray
    box: np.ndarray | None


def detect_faces(
    samples: Sequence[FaceSample], n_jobs: int = 2, max_face_width: float = 200.0,
    progress: Callable[[Iterable[DetectedFace]], Iterable[DetectedFace]] | None = None,
    make_detector: Callable[[], HaarFaceDetector] = HaarFaceDetector,
) -> list[DetectedFace]:
    """Read, detect (the default detector) and shrink every sample, in ``n_jobs`` threads
    (each with its own detector: a cascade must not be shared between threads)."""
    local = threading.local()
    found: list[DetectedFace] = []

    def work(k: int) -> DetectedFace:
        if not hasattr(local, "detector"):
            local.detector = make_detector()
        sample = samples[k]
        image = sample.load_image()
        boxes = local.detector.detect(image)
        m = match_detection(boxes, sample.points)
        grey, f = shrink_face(image, sample.points, max_face_width)
        return DetectedFace(grey, f, boxes, None if m is None else boxes[m])

    with ThreadPoolExecutor(max(1, n_jobs)) as pool:
        done = pool.map(work, range(len(samples)))
        found = list(progress(done) if progress else done)
    return found


def no_face_frames(path: Path | None = None) -> list[np.ndarray]:
    """Grey frames without a face for the quality stage: the first half of
    ``videos/no_face.mp4`` (the second half is kept for testing); none without the file."""
    path = path or data_root() / "videos" / "no_face.mp4"
    if not path.is_file():
        return []
    import cv2

    frames = [cv2.cvtColor(f, cv2.COLOR_BGR2GRAY) for f in video_frames(path)]
    return frames[: len(frames) // 2]
