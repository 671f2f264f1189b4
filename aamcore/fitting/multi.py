"""Tracking every face in the frame, each under an id that stays while it is tracked.

One face is the :class:`~aamcore.fitting.tracker.Tracker`'s case, and with
``max_faces=1`` :class:`MultiTracker` is that tracker and nothing more. With more,
each face has a tracker of its own that only follows it (no search), and one search
for faces not yet tracked runs over the frame with the tracked faces blanked out:
on the frame a face is lost, every :attr:`NewFaces.every` frames while fewer than
``max_faces`` are tracked, and on the single tracker's schedule while none is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from aamcore.detection.haar import HaarFaceDetector, to_grey_uint8
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.result import FitResult
from aamcore.fitting.search import SearchSchedule
from aamcore.fitting.tracker import SEARCH_DEG, TURN_DEG, FaceDetector, Refit, Tracker
from aamcore.fitting.upright import mapped, roll_of, rotated_view

FOREHEAD = 0.35
"""A tracked face is blanked out for the search over its landmarks' box widened by this share
of its size on each side (and as much again above: a Haar box holds the forehead)."""


@dataclass(frozen=True)
class NewFaces:
    """How a tracker of several faces looks for new ones and keeps ids.

    Attributes
    ----------
    every : int
        Search for faces not yet tracked every this many frames while fewer than
        ``max_faces`` are tracked, upright and in the frame turned by 25 degrees in turn
        (a Haar pass is 7-10 ms at 960x540: every fifth frame costs under 2 ms a frame on
        average, ``bench/bench_multiface.py``).
    regain_frames : int
        A face found again within this many frames of being lost ...
    regain_distance : float
        ... and within this share of its width of where it was lost keeps its id;
        any other face found gets a new one.
    overlap : float
        Two tracked faces whose landmark boxes overlap more than this (intersection over
        the smaller box) are one face: the one that moved less keeps it.
    """

    every: int = 5
    regain_frames: int = 15
    regain_distance: float = 0.5
    overlap: float = 0.5

    def __post_init__(self) -> None:
        if self.every < 1 or self.regain_frames < 0 or self.regain_distance < 0:
            raise ValueError(f"not a new-face policy: {self}")
        if not 0.0 < self.overlap <= 1.0:
            raise ValueError(f"overlap must be in (0, 1], got {self.overlap}")


@dataclass(frozen=True, eq=False)
class TrackedFace:
    """One face's fit in one frame.

    Attributes
    ----------
    face_id : int
        The face's id: the same while it is tracked (and when it is found again within
        :attr:`NewFaces.regain_frames` at the same place), never reused otherwise.
    fit : FitResult
    """

    face_id: int
    fit: FitResult


@dataclass(eq=False)
class _Face:
    face_id: int
    tracker: Tracker
    moved: float = 0.0


@dataclass(frozen=True)
class _Lost:
    face_id: int
    centre: np.ndarray
    width: float
    frame: int


@dataclass(eq=False)
class _Ids:
    """Face ids: new ones counted up, a lost face's given back when it is found again soon
    and near."""

    policy: NewFaces
    next_id: int = 0
    lost: list[_Lost] = field(default_factory=list)

    def lose(self, face_id: int, fit: FitResult, frame: int) -> None:
        self.lost.append(_Lost(face_id, fit.points.mean(axis=0), float(np.ptp(fit.points[:, 0])),
                               frame))

    def assign(self, fit: FitResult, frame: int) -> int:
        self.lost = [g for g in self.lost if frame - g.frame <= self.policy.regain_frames]
        centre = fit.points.mean(axis=0)
        near = [g for g in self.lost
                if np.linalg.norm(centre - g.centre) <= self.policy.regain_distance * g.width]
        if near:
            best = min(near, key=lambda g: float(np.linalg.norm(centre - g.centre)))
            self.lost.remove(best)
            return best.face_id
        self.next_id += 1
        return self.next_id - 1

    def forget(self) -> None:
        self.lost.clear()


def landmark_box(points: np.ndarray) -> np.ndarray:
    """``x0, y0, x1, y1`` of the landmarks ``(N, 2)``."""
    return np.concatenate([points.min(axis=0), points.max(axis=0)])


def overlap(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection of two ``x0, y0, x1, y1`` boxes over the smaller one's area."""
    w = min(a[2], b[2]) - max(a[0], b[0])
    h = min(a[3], b[3]) - max(a[1], b[1])
    if w <= 0 or h <= 0:
        return 0.0
    smaller = min((a[2] - a[0]) * (a[3] - a[1]), (b[2] - b[0]) * (b[3] - b[1]))
    return float(w * h / smaller) if smaller > 0 else 1.0


def blanked(grey: np.ndarray, fits: list[FitResult]) -> np.ndarray:
    """``grey`` with each fitted face covered by the frame's mean grey (a copy when any)."""
    if not fits:
        return grey
    out = grey.copy()
    fill = int(grey.mean())
    h, w = grey.shape[:2]
    for fit in fits:
        x0, y0, x1, y1 = landmark_box(fit.points)
        mx, my = FOREHEAD * (x1 - x0), FOREHEAD * (y1 - y0)
        left, right = int(max(0, x0 - mx)), int(min(w, math.ceil(x1 + mx)))
        top, bottom = int(max(0, y0 - 2 * my)), int(min(h, math.ceil(y1 + my)))
        if right > left and bottom > top:
            out[top:bottom, left:right] = fill
    return out


class MultiTracker:
    """Track up to ``max_faces`` faces from frame to frame, each under a stable id.

    Parameters
    ----------
    fitter : Fitter
    detector : FaceDetector, optional
        Haar by default; shared by every face's search.
    max_faces : int
        At most this many faces tracked (1: the single-face
        :class:`~aamcore.fitting.tracker.Tracker`, unchanged).
    search : SearchSchedule, optional
        Which frames are searched while no face is tracked.
    refit : Refit, optional
        Each face tracker's refits from the mean face.
    new_faces : NewFaces, optional
        How faces not yet tracked are looked for, and ids kept.
    """

    def __init__(self, fitter: Fitter, detector: FaceDetector | None = None, max_faces: int = 1,
                 search: SearchSchedule | None = None, refit: Refit | None = None,
                 new_faces: NewFaces | None = None) -> None:
        if max_faces < 1:
            raise ValueError(f"max_faces must be at least 1, got {max_faces}")
        self.fitter = fitter
        self.detector = detector or HaarFaceDetector()
        self.max_faces = max_faces
        self.search = search or SearchSchedule()
        self.refit = refit
        self.new_faces = new_faces or NewFaces()
        self.single = Tracker(fitter, self.detector, search, refit)
        """The one face's tracker when ``max_faces`` is 1."""
        self.faces: list[_Face] = []
        self.ids = _Ids(self.new_faces)
        self.frame = -1
        self.size: tuple[int, ...] = ()
        self.misses = 0
        self.searches = 0
        """Haar passes run by the search for new faces (``max_faces`` > 1)."""
        self._current: int | None = None
        self._due = 0
        self._roll = 0.0
        self._side = 1.0

    @property
    def detections(self) -> int:
        """Frames on which a search ran."""
        return self.single.detections if self.max_faces == 1 else self.searches

    def reset(self) -> None:
        """Forget every face: the next frame starts from a search, and ids are not regained."""
        self.single.reset()
        self._current = None
        self.faces = []
        self.ids.forget()
        self.misses = 0

    def track(self, image: np.ndarray) -> tuple[list[TrackedFace], FitResult | None]:
        """The good fits of the faces in ``image`` (by id), and a failed fit when there is
        none (the single tracker's failed detection), else None.

        Raises
        ------
        ValueError
            For something that is not an image array.
        """
        self.frame += 1
        if self.max_faces == 1:
            return self._track_one(image)
        if not isinstance(image, np.ndarray) or image.ndim not in (2, 3) or image.size == 0:
            raise ValueError(f"not an image: {type(image).__name__} "
                             f"{getattr(image, 'shape', '')}")
        if image.shape[:2] != self.size:
            self.size = image.shape[:2]
            self.reset()
        kept: list[tuple[_Face, FitResult]] = []
        lost = False
        for face in self.faces:
            before = face.tracker.last
            result = face.tracker.follow(image)
            if result.ok:
                face.moved = _step(before, result) if before is not None else 0.0
                kept.append((face, result))
            else:
                lost = True
                if before is not None:
                    self.ids.lose(face.face_id, before, self.frame)
        kept = self._distinct(kept)
        found = self._search(image, [fit for _, fit in kept], lost)
        for fit in found:
            face = _Face(self.ids.assign(fit, self.frame),
                         Tracker(self.fitter, self.detector, self.search, self.refit))
            face.tracker.adopt(fit, self.size)
            kept.append((face, fit))
        kept.sort(key=lambda pair: pair[0].face_id)
        self.faces = [face for face, _ in kept]
        if kept:
            self.misses = 0
            self._roll = roll_of(kept[0][1])
        return [TrackedFace(face.face_id, fit) for face, fit in kept], None

    def _track_one(self, image: np.ndarray) -> tuple[list[TrackedFace], FitResult | None]:
        tracker = self.single
        had = tracker.last
        fit = tracker.track(image)
        if fit is None or not fit.ok:
            if had is not None and self._current is not None:
                self.ids.lose(self._current, had, self.frame)
            self._current = None
            return [], fit
        if self._current is None:
            self._current = self.ids.assign(fit, self.frame)
        return [TrackedFace(self._current, fit)], None

    def _distinct(self, kept: list[tuple[_Face, FitResult]]) -> list[tuple[_Face, FitResult]]:
        """One fit per face: of two that overlap, the one that moved less stays (the other
        slid onto it as the faces crossed)."""
        out: list[tuple[_Face, FitResult]] = []
        for face, fit in sorted(kept, key=lambda pair: pair[0].moved):
            box = landmark_box(fit.points)
            if all(overlap(box, landmark_box(other.points)) <= self.new_faces.overlap
                   for _, other in out):
                out.append((face, fit))
            else:
                self.ids.lose(face.face_id, fit, self.frame)
        return out

    def _search(self, image: np.ndarray, tracked: list[FitResult], lost: bool
                ) -> list[FitResult]:
        """Good fits of faces not in ``tracked`` (at most ``max_faces`` in all), on the frames
        the policy searches."""
        room = self.max_faces - len(tracked)
        if room <= 0:
            return []
        if tracked:
            due = lost or self.frame % self.new_faces.every == 0
            angles = []
            if due:
                # upright and turned in turn: a newcomer rolled past Haar's reach is found
                # within two searches, at one pass's cost
                self._due += 1
                angles = [0.0] if self._due % 2 else [self._turn()]
        else:
            upright, turned = self.search.passes(self.misses)
            angles = [0.0] * upright + [self._turn()] * turned
        if not angles:
            if not tracked:
                self.misses += 1
            return []
        grey = to_grey_uint8(image)
        found: list[FitResult] = []
        for angle in angles:
            self.searches += 1
            for fit in self._fits(image, blanked(grey, tracked + found), angle):
                box = landmark_box(fit.points)
                if all(overlap(box, landmark_box(other.points)) <= self.new_faces.overlap
                       for other in tracked + found):
                    found.append(fit)
                if len(found) >= room:
                    return found
            if found:
                break
        if not tracked and not found:
            self.misses += 1
        return found

    def _fits(self, image: np.ndarray, grey: np.ndarray, angle: float) -> list[FitResult]:
        """The good fits of the faces Haar finds in ``grey`` turned by ``-angle``, largest
        first."""
        if angle == 0.0:
            boxes = self.detector.detect(grey)
            fits = [self.fitter.fit_box(image, box) for box in boxes]
        else:
            boxes = self.detector.detect(rotated_view(grey, angle)[0])
            if len(boxes) == 0:
                return []
            view, to_view = rotated_view(image, angle)
            back = to_view.inverse()
            fits = [mapped(self.fitter.fit_box(view, box), back) for box in boxes]
        return [fit for fit in fits if fit.ok]

    def _turn(self) -> float:
        """The angle to turn the frame by in a search besides upright (as the single
        tracker's)."""
        if abs(self._roll) > math.radians(TURN_DEG):
            return self._roll
        self._side = -self._side
        return self._side * math.radians(SEARCH_DEG)


def _step(before: FitResult, after: FitResult) -> float:
    """How far a face moved between two fits, in its widths."""
    width = max(float(np.ptp(before.points[:, 0])), 1.0)
    return float(np.linalg.norm(after.points.mean(axis=0) - before.points.mean(axis=0)) / width)
