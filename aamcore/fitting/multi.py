"""Tracking every face in the frame, each under an id that stays while it is tracked.

Each face has a :class:`~aamcore.fitting.tracker.Tracker` of its own that only follows it
(no search), and one search for faces not yet tracked runs over the frame with the tracked
faces blanked out: on the frame a face is lost, every :attr:`NewFaces.every` frames while
fewer than ``max_faces`` are tracked, and on the search schedule while none is. One path
for any number of faces: with ``max_faces=1`` it tracks as the single tracker does (the
largest face found, its failed fit given back), under id 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from aamcore import defaults
from aamcore.detection.haar import HaarFaceDetector, to_grey_uint8
from aamcore.fitting.config import NewFaces
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.result import FitResult
from aamcore.fitting.search import SearchSchedule
from aamcore.fitting.tracker import FaceDetector, Refit, Tracker, new_size, turn_for_search
from aamcore.fitting.upright import mapped, roll_of, rotated_view
from aamcore.model.similarity import centroid

__all__ = ["MultiTracker", "NewFaces", "TrackedFace"]

FOREHEAD = 0.35
"""A tracked face is blanked out for the search over its landmarks' box widened by this share
of its size on each side (and as much again above: a Haar box holds the forehead)."""


@dataclass(frozen=True, eq=False)
class TrackedFace:
    """One face's fit in one frame.

    Attributes
    ----------
    face_id : int
        The face's id: the same while it is tracked (and when it is found again within
        :attr:`NewFaces.regain_frames` at the same place), never reused otherwise; with
        ``max_faces=1``, always 0 (one face at a time).
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
    hidden: bool


@dataclass(eq=False)
class _Ids:
    """Face ids: new ones counted up, a lost face's given back when it is found again soon
    and near."""

    policy: NewFaces
    next_id: int = 0
    lost: list[_Lost] = field(default_factory=list)

    def lose(self, face_id: int, fit: FitResult, frame: int, hidden: bool = False) -> None:
        self.lost.append(_Lost(face_id, fit.points.mean(axis=0), float(np.ptp(fit.points[:, 0])),
                               frame, hidden))

    def alive(self, frame: int) -> list[_Lost]:
        """The lost faces whose ids can still be regained on ``frame``."""
        policy = self.policy
        self.lost = [g for g in self.lost if frame - g.frame <= (
            policy.hidden_frames if g.hidden else policy.regain_frames)]
        return self.lost

    def assign(self, fit: FitResult, frame: int, max_faces: int) -> int:
        if max_faces == 1:  # one face at a time: the face, whoever it is
            return 0
        self.alive(frame)
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


def blanked(grey: np.ndarray, fits: list[FitResult], offset: tuple[int, int] = (0, 0)
            ) -> np.ndarray:
    """``grey`` (a window of the frame whose top-left corner is at ``offset``) with each fitted
    face covered by its mean grey (a copy when any)."""
    if not fits:
        return grey
    out = grey.copy()
    fill = int(grey.mean())
    h, w = grey.shape[:2]
    for fit in fits:
        x0, y0, x1, y1 = landmark_box(fit.points) - np.tile(offset, 2)
        mx, my = FOREHEAD * (x1 - x0), FOREHEAD * (y1 - y0)
        left, right = int(max(0, x0 - mx)), int(min(w, math.ceil(x1 + mx)))
        top, bottom = int(max(0, y0 - 2 * my)), int(min(h, math.ceil(y1 + my)))
        if right > left and bottom > top:
            out[top:bottom, left:right] = fill
    return out


class TrackingChoices(Protocol):
    """What :meth:`MultiTracker.configured` reads of a tracker's configuration."""

    max_faces: int
    search: SearchSchedule
    refit: Refit
    new_faces: NewFaces


class MultiTracker:
    """Track up to ``max_faces`` faces from frame to frame, each under a stable id.

    Parameters
    ----------
    fitter : Fitter
    detector : FaceDetector, optional
        Haar by default; shared by every face's search.
    max_faces : int
        At most this many faces tracked.
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
        if not 1 <= max_faces <= defaults.MAX_FACES:
            raise ValueError(f"max_faces must be 1 to {defaults.MAX_FACES}, got {max_faces}")
        self.fitter = fitter
        self.detector = detector or HaarFaceDetector()
        self.max_faces = max_faces
        self.search = search or SearchSchedule()
        self.refit = refit
        self.new_faces = new_faces or NewFaces()
        self.faces: list[_Face] = []
        self.ids = _Ids(self.new_faces)
        self.frame = -1
        self.size: tuple[int, ...] = ()
        self.misses = 0
        self.searches = 0
        """Haar passes run by the search for faces."""
        self.detections = 0
        """Frames on which a search ran."""
        self._due = 0
        self._roll = 0.0
        self._side = 1.0

    @classmethod
    def configured(cls, fitter: Fitter, config: TrackingChoices,
                   detector: FaceDetector | None = None) -> MultiTracker:
        """The tracker of a :class:`~aamcore.operators.options.FitOptions`' choices."""
        return cls(fitter, detector, config.max_faces, config.search, config.refit,
                   config.new_faces)

    def reset(self) -> None:
        """Forget every face: the next frame starts from a search, and ids are not regained."""
        self.faces = []
        self.ids.forget()
        self.misses = 0
        self._roll = 0.0

    def track(self, image: np.ndarray) -> tuple[list[TrackedFace], FitResult | None]:
        """The good fits of the faces in ``image`` (by id), and when there is none the failed
        fit of the largest face the search found (None if it found none).

        Raises
        ------
        ValueError
            For something that is not an image array.
        """
        self.frame += 1
        if new_size(image, self.size):
            self.size = image.shape[:2]
            self.reset()
        kept: list[tuple[_Face, FitResult]] = []
        gone: list[tuple[int, FitResult]] = []
        for face in self.faces:
            before = face.tracker.last
            result = face.tracker.follow(image)
            if result.ok:
                face.moved = _step(before, result) if before is not None else 0.0
                kept.append((face, result))
            elif before is not None:
                gone.append((face.face_id, before))
        kept = self._distinct(kept)
        for face_id, before in gone:
            box = landmark_box(before.points)
            hidden = any(overlap(box, landmark_box(fit.points)) > 0 for _, fit in kept)
            self.ids.lose(face_id, before, self.frame, hidden)
        lost = bool(gone)
        found, failed = self._search(image, [fit for _, fit in kept], lost)
        for fit in found:
            face = _Face(self.ids.assign(fit, self.frame, self.max_faces),
                         Tracker(self.fitter, self.detector, self.search, self.refit))
            face.tracker.adopt(fit, self.size)
            kept.append((face, fit))
        kept.sort(key=lambda pair: pair[0].face_id)
        self.faces = [face for face, _ in kept]
        if kept:
            self.misses = 0
            self._roll = roll_of(kept[0][1])
        return [TrackedFace(face.face_id, fit) for face, fit in kept], (
            None if kept else failed)

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
                self.ids.lose(face.face_id, fit, self.frame, hidden=True)
        return out

    def _search(self, image: np.ndarray, tracked: list[FitResult], lost: bool
                ) -> tuple[list[FitResult], FitResult | None]:
        """Good fits of faces not in ``tracked`` (at most ``max_faces`` in all), on the frames
        the policy searches: around the faces lost lately, then over the whole frame; and
        the first failed fit of a face it found."""
        room = self.max_faces - len(tracked)
        if room <= 0:
            return [], None
        if tracked:
            angles = []
            if lost:  # found again on the frame it is lost on, as a lone face is
                angles = [0.0]
            elif self.frame % self.new_faces.every == 0:
                # upright and turned in turn: a newcomer rolled past Haar's reach is found
                # within two searches, at one pass's cost
                self._due += 1
                angles = [0.0] if self._due % 2 else [self._turn()]
        else:
            upright, turned = self.search.passes(self.misses)
            angles = [0.0] * upright + [self._turn()] * turned
        near = [gone for gone in self.ids.alive(self.frame)
                if (self.frame - gone.frame) % 2 == 1] if tracked and not lost else []
        self.detections += bool(near or angles)
        found, failed = self._passes(image, tracked, near, angles, room)
        if not tracked and not found:
            self.misses += 1
        return found, failed

    def _passes(self, image: np.ndarray, tracked: list[FitResult], near: list[_Lost],
                angles: list[float], room: int) -> tuple[list[FitResult], FitResult | None]:
        """The search's Haar passes: around each face lost lately, then in the frame turned
        by each angle until one finds a face."""
        grey = to_grey_uint8(image) if tracked or any(angles) else None
        found: list[FitResult] = []
        failed = None
        for gone in near:  # every second frame
            self.searches += 1
            found += self._new(self._fits_near(image, grey, gone, tracked + found),
                               tracked + found, room - len(found))
            if len(found) >= room:
                return found, None
        for angle in angles:
            self.searches += 1
            taken = tracked + found
            fits = self._fits(image, grey, angle, taken, room - len(found))
            failed = failed or next((fit for fit in fits if not fit.ok), None)
            found += self._new(fits, taken, room - len(found))
            if found:
                break
        return found, failed

    def _new(self, fits: list[FitResult], taken: list[FitResult], room: int) -> list[FitResult]:
        """The first ``room`` good fits of ``fits`` that are none of ``taken`` nor of each
        other."""
        out: list[FitResult] = []
        for fit in fits:
            box = landmark_box(fit.points)
            if fit.ok and len(out) < room and all(
                    overlap(box, landmark_box(other.points)) <= self.new_faces.overlap
                    for other in taken + out):
                out.append(fit)
        return out

    def _boxes(self, grey: np.ndarray, taken: list[FitResult],
               offset: tuple[float, float] = (0.0, 0.0)) -> list[np.ndarray]:
        """Haar's boxes in ``grey`` (moved by ``offset``) that are not over a face in
        ``taken`` (so that no fit is spent on it)."""
        out = []
        for x, y, w, h in self.detector.detect(grey):
            box = np.array([x + offset[0], y + offset[1], w, h], np.float64)
            corners = np.r_[box[:2], box[:2] + box[2:]]
            if all(overlap(corners, landmark_box(fit.points)) <= self.new_faces.overlap
                   for fit in taken):
                out.append(box)
        return out

    def _fits(self, image: np.ndarray, grey: np.ndarray | None, angle: float,
              taken: list[FitResult], room: int) -> list[FitResult]:
        """The fits of the faces Haar finds in the frame turned by ``-angle`` (the faces of
        ``taken`` blanked out), largest first, until ``room`` are good or as many failed."""
        if angle == 0.0:
            # nothing to blank: the frame itself is searched (a detector service is asked
            # about the frame it was sent, not a copy)
            searched = image if not taken else blanked(grey, taken)  # type: ignore[arg-type]
            return self._fitted(image, self._boxes(searched, taken), room)
        view, to_view = rotated_view(image, angle)
        turned = [mapped(fit, to_view) for fit in taken]
        boxes = self._boxes(rotated_view(grey, angle)[0], turned)  # type: ignore[arg-type]
        if not boxes:
            return []
        back = to_view.inverse()
        return [mapped(fit, back) for fit in self._fitted(view, boxes, room)]

    def _fitted(self, image: np.ndarray, boxes: list[np.ndarray], room: int
                ) -> list[FitResult]:
        """The fits of ``boxes`` in order, until ``room`` are good or as many failed."""
        fits: list[FitResult] = []
        for box in boxes:
            fits.append(self.fitter.fit_box(image, box))
            if sum(f.ok for f in fits) >= room or sum(not f.ok for f in fits) >= room:
                break
        return fits

    def _fits_near(self, image: np.ndarray, grey: np.ndarray | None, gone: _Lost,
                   taken: list[FitResult]) -> list[FitResult]:
        """The good fits of the faces Haar finds around where ``gone`` was lost (a window of
        three of its widths), with the faces of ``taken`` blanked out."""
        assert grey is not None
        h, w = grey.shape[:2]
        half = 1.5 * gone.width
        x0, x1 = int(max(0, gone.centre[0] - half)), int(min(w, gone.centre[0] + half))
        y0, y1 = int(max(0, gone.centre[1] - 1.3 * half)), int(min(h, gone.centre[1] + half))
        if x1 - x0 < 24 or y1 - y0 < 24:
            return []
        window = blanked(np.ascontiguousarray(grey[y0:y1, x0:x1]), taken, (x0, y0))
        boxes = self._boxes(window, taken, (x0, y0))
        return [fit for fit in (self.fitter.fit_box(image, box) for box in boxes) if fit.ok]

    def _turn(self) -> float:
        """The angle to turn the frame by in a search besides upright (as the single
        tracker's)."""
        angle, self._side = turn_for_search(self._roll, self._side)
        return angle


def _step(before: FitResult, after: FitResult) -> float:
    """How far a face moved between two fits, in its widths."""
    width = max(float(np.ptp(before.points[:, 0])), 1.0)
    return float(np.linalg.norm(centroid(after.points) - centroid(before.points)) / width)
