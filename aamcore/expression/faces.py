"""Labelled expression faces as the stack sees them: each image fitted as a stream's first frame.

:func:`stack_observations` fits images as the stack fits the first frame of a
stream (a new stream, the Haar detector with the detector service's settings,
the fitter with the default algorithm and failure test, the landmarks and ``c``
at the precision of the ``Fit`` message). :func:`fit_faces` does so for the
faces of the expression sets (:mod:`aamcore.io.expression_sets`) and returns
:class:`LabelledFaces`: the fits as arrays, the class, person and set of each
face, and their observations, read from the image files when asked for (five
thousand frames do not stay in memory). :meth:`LabelledFaces.save` and
:meth:`LabelledFaces.load` keep the fits of a model for the benchmark.
"""

from __future__ import annotations

import threading
from collections.abc import Iterable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from aamcore import defaults
from aamcore.detection.haar import HaarFaceDetector
from aamcore.expression.crop import N_LANDMARKS, FaceObservation
from aamcore.fitting.config import FITTER, FitterConfig
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.fitting.result import appearance_of
from aamcore.fitting.tracker import Tracker
from aamcore.io.expression_sets import ExpressionSet
from aamcore.io.sample import DatasetError, read_image
from aamcore.progress import note, progress

FACES_VERSION = 1
"""Bump when the fitting of the faces changes: saved fits of another version are refitted."""


def stack_observations(model: FittingModel, images: Iterable[np.ndarray],
                       config: FitterConfig = FITTER) -> Iterator[FaceObservation]:
    """Each image fitted as the first frame of a stream of the stack, as an observation.

    Parameters
    ----------
    model : FittingModel
    images : iterable of (H, W) or (H, W, 3) uint8 arrays
    config : FitterConfig
        The fitting the stack does (its appearance is sampled whatever it says).

    Yields
    ------
    FaceObservation
        Without landmarks (reason ``"no face"``) where Haar found none.
    """
    fitter = Fitter.from_config(model, replace(config, appearance=True, occlusion=False))
    tracker = Tracker(fitter, HaarFaceDetector(**defaults.DETECTOR))
    for image in images:
        tracker.reset()
        result = tracker.track(image)
        if result is None:
            yield FaceObservation.from_arrays(image, None, None, True, "no face")
        else:
            yield FaceObservation.from_arrays(image, result.points, appearance_of(result),
                                              result.failed, result.reason)


class Observations(Sequence[FaceObservation]):
    """The observations of :class:`LabelledFaces`, each read from its image file when asked."""

    def __init__(self, faces: LabelledFaces) -> None:
        self._faces = faces

    def __len__(self) -> int:
        return len(self._faces.paths)

    def __getitem__(self, i):  # type: ignore[override]
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(len(self)))]
        return self._faces.observation(int(i))


@dataclass(eq=False)
class LabelledFaces:
    """Labelled faces and the stack's fit of each.

    Attributes
    ----------
    paths : (n,) str array
        Image files.
    labels, posers, sets : (n,) str arrays
        Class code, person and expression set of each face.
    landmarks : (n, 68, 2) float64 array
        NaN where no face was found.
    appearance : (n, k) float64 array
        The fit's ``c``; NaN where no face was found or the fit has none (a failed fit of
        a landmark regressor is not sampled).
    fit_failed : (n,) bool array
        The fitter's own test rejected the fit (or no face).
    reasons : (n,) str array
        The fitter's reason.
    images : list of arrays, optional
        The frames themselves, kept when few (JAFFE); else read again when asked.
    """

    paths: np.ndarray
    labels: np.ndarray
    posers: np.ndarray
    sets: np.ndarray
    landmarks: np.ndarray
    appearance: np.ndarray
    fit_failed: np.ndarray
    reasons: np.ndarray
    images: list[np.ndarray] | None = None

    @property
    def names(self) -> np.ndarray:
        """File name of each face, (n,)."""
        return np.array([Path(p).name for p in self.paths])

    @property
    def no_face(self) -> np.ndarray:
        """Faces (n,) without landmarks (no detection)."""
        return np.isnan(self.landmarks[:, 0, 0])

    @property
    def observations(self) -> Observations:
        return Observations(self)

    def image(self, i: int) -> np.ndarray:
        """The frame of face ``i`` as the stack got it (BGR or grey, uint8)."""
        if self.images is not None:
            return self.images[i]
        path = Path(self.paths[i])
        return read_image(path, grey=path.suffix.lower() in (".tiff", ".tif"))

    def observation(self, i: int) -> FaceObservation:
        """Face ``i`` as the expression stage sees it (without landmarks, no image is read:
        the gate needs none, and an unreadable file has none)."""
        found = not self.no_face[i]
        sampled = found and bool(np.isfinite(self.appearance[i]).all())
        return FaceObservation.from_arrays(
            self.image(i) if found else np.zeros((1, 1), np.uint8),
            self.landmarks[i] if found else None,
            self.appearance[i] if sampled else None, bool(self.fit_failed[i]),
            str(self.reasons[i]))

    def subset(self, keep: np.ndarray) -> LabelledFaces:
        """The faces where ``keep`` (n,) is true (a boolean mask or indices)."""
        index = np.flatnonzero(keep) if np.asarray(keep).dtype == bool else np.asarray(keep)
        images = None if self.images is None else [self.images[i] for i in index]
        return LabelledFaces(self.paths[index], self.labels[index], self.posers[index],
                             self.sets[index], self.landmarks[index], self.appearance[index],
                             self.fit_failed[index], self.reasons[index], images)

    @classmethod
    def concatenate(cls, parts: Sequence[LabelledFaces]) -> LabelledFaces:
        """The faces of ``parts`` one after the other (images kept only if all keep them)."""
        images = None
        if all(p.images is not None for p in parts):
            images = [im for p in parts for im in p.images or []]
        fields = ("paths", "labels", "posers", "sets", "landmarks", "appearance",
                  "fit_failed", "reasons")
        return cls(*(np.concatenate([getattr(p, f) for p in parts]) for f in fields),
                   images=images)

    def save(self, path: str | Path) -> None:
        """Write the fits and labels (never the images) to an ``.npz`` file."""
        np.savez(path, version=FACES_VERSION, paths=self.paths, labels=self.labels,
                 posers=self.posers, sets=self.sets, landmarks=self.landmarks,
                 appearance=self.appearance, fit_failed=self.fit_failed, reasons=self.reasons)

    @classmethod
    def load(cls, path: str | Path) -> LabelledFaces | None:
        """The faces :meth:`save` wrote, or None when the file is of another version."""
        with np.load(path, allow_pickle=False) as f:
            if int(f["version"]) != FACES_VERSION:
                return None
            return cls(f["paths"], f["labels"], f["posers"], f["sets"], f["landmarks"],
                       f["appearance"], f["fit_failed"], f["reasons"])


UNREADABLE = "unreadable image"
"""The reason of a face whose image file is missing or cannot be decoded (skipped)."""
FIT_WORKERS = 2
"""Threads that fit faces at once: detection and fitting release the GIL for most of their
time, so two threads on two cores fit nearly twice as fast."""


def fit_faces(model: FittingModel, data: ExpressionSet, config: FitterConfig = FITTER,
              keep_images: bool = False, select: np.ndarray | None = None,
              workers: int = FIT_WORKERS) -> LabelledFaces:
    """The faces of ``data`` (of ``select`` (n,) when given), each fitted by ``model`` as the
    stack fits a stream's first frame, by ``workers`` threads with a tracker each. An image
    file that is missing or cannot be decoded is skipped: a face without landmarks whose
    reason (:data:`UNREADABLE`) names it; their count and the first are said.

    Raises
    ------
    DatasetError
        When nothing of ``data`` is selected.
    """
    samples = data.samples if select is None else [data.samples[i] for i in
                                                   np.flatnonzero(select)]
    if not samples:
        raise DatasetError(f"{data.root}: no face of {data.name} to fit")
    grey = data.name == "jaffe"
    n, k = len(samples), model.aam.n_appearance
    landmarks, appearance = np.full((n, N_LANDMARKS, 2), np.nan), np.full((n, k), np.nan)
    failed, reasons = np.ones(n, bool), np.full(n, "no face", dtype=object)
    images: list[np.ndarray | None] = [None] * n
    done = iter(progress(range(n), f"fitting {data.name}", n))
    lock = threading.Lock()

    def fit(part: range) -> None:
        readable: list[int] = []

        def read() -> Iterator[np.ndarray]:
            for i in part:
                images[i], reasons[i] = _read(samples[i].image_path, grey)
                if images[i] is not None:
                    readable.append(i)
                    yield images[i]
                with lock:
                    next(done, None)

        # stack_observations takes one image for each observation it gives
        for obs in stack_observations(model, read(), config):
            i = readable[-1]
            if obs.landmarks.size:
                landmarks[i] = obs.landmarks
                appearance[i, :obs.appearance.size] = obs.appearance[:k]
            failed[i], reasons[i] = obs.fit_failed, obs.fit_reason
            if not keep_images:
                images[i] = None

    parts = [range(w, n, workers) for w in range(max(1, min(workers, n)))]
    with ThreadPoolExecutor(len(parts)) as pool:
        for future in [pool.submit(fit, part) for part in parts]:
            future.result()
    next(done, None)
    _say_skipped(data.name, reasons)
    # an unreadable face keeps its place among the images: a frame of one black pixel
    kept = [np.zeros((1, 1), np.uint8) if im is None else im for im in images]
    return LabelledFaces(np.array([str(s.image_path) for s in samples]),
                         np.array([s.label for s in samples]),
                         np.array([s.poser for s in samples]), np.full(n, data.name),
                         landmarks, appearance, failed, reasons.astype(str),
                         kept if keep_images else None)


def _read(path: Path, grey: bool) -> tuple[np.ndarray | None, str]:
    """The image of ``path``, or None and the reason (:data:`UNREADABLE`) it cannot be read;
    "no face" until fitted."""
    try:
        return read_image(path, grey=grey), "no face"
    except DatasetError as exc:
        return None, f"{UNREADABLE}: {exc}"


def _say_skipped(name: str, reasons: np.ndarray) -> None:
    """One line of how many of a set's image files were skipped, unreadable, and the first."""
    skipped = [str(r) for r in reasons if str(r).startswith(UNREADABLE)]
    if skipped:
        note(f"{name}: {len(skipped)} of {len(reasons)} image files skipped, unreadable (the "
             f"first: {skipped[0][len(UNREADABLE) + 2:]})")
