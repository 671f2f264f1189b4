"""Tracking a face from frame to frame, re-detecting when there is none or a fit fails."""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from aamcore.detection.haar import HaarFaceDetector, to_grey_uint8
from aamcore.fitting.config import DEFAULT_REFIT, NEVER, Refit
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.result import FitResult
from aamcore.fitting.search import SearchSchedule
from aamcore.fitting.upright import mapped, roll_of, rotated_view
from aamcore.model.similarity import centroid

__all__ = ["DEFAULT_REFIT", "NEVER", "FaceDetector", "Refit", "Tracker", "fit_upright"]

TURN_DEG = 20.0
"""A lost face last seen rolled further than this is looked for in the frame turned by
its roll as well as upright. Nearer upright the upright pass mostly finds it (Haar at the
default settings finds 87, 73 and 51 % of the held-out LFPW faces turned by 10, 15 and 20
degrees: ``python -m bench detection``, its roll-reach table), so the turned pass looks
further out, to either side in turn: a face lost at a small roll that comes back rolled
the other way (under a hand, say) is found there."""
MOVING = 0.03
"""A face whose centre moved more than this share of its width between two frames is
tracked from where that motion takes it; a smaller move is mostly the fits' own jitter,
which extrapolated would only add to it."""
UPRIGHT_DEG = 10.0
"""A refit of a face rolled further than this is made in the frame turned upright about the
face (the cascade from the mean face is trained on upright faces, as Haar finds them)."""
SEARCH_DEG = 25.0
"""Without such a roll, each search turns the frame by this much, to one side and then
to the other on the next search (Haar finds faces within about 20 degrees of
upright)."""


class FaceDetector(Protocol):
    """Anything that finds face boxes: ``detect(image) -> (K, 4)`` ``x, y, w, h``, largest first."""

    def detect(self, image: np.ndarray) -> np.ndarray: ...


class Tracker:
    """Track a face from frame to frame, re-detecting when there is none or a fit fails.

    Parameters
    ----------
    fitter : Fitter
    detector : FaceDetector, optional
        Haar by default.
    search : SearchSchedule, optional
        Which frames without a face are searched, and how (the default's eager start,
        then spread passes).
    refit : Refit, optional
        When a tracked frame is also fitted from the mean face (:data:`DEFAULT_REFIT`;
        :data:`NEVER`: tracking only).
    """

    def __init__(self, fitter: Fitter, detector: FaceDetector | None = None,
                 search: SearchSchedule | None = None, refit: Refit | None = None) -> None:
        self.fitter = fitter
        self.refit = DEFAULT_REFIT if refit is None else refit
        self.refits = 0
        """Refits run (:attr:`refit`)."""
        self.kept = 0
        """Refits kept instead of the tracked fit."""
        self._since = 0
        self.detector = detector or HaarFaceDetector()
        self.search = search or SearchSchedule()
        self.misses = 0
        """Frames in a row without a good fit (the search schedule's clock)."""
        self.last: FitResult | None = None
        self.before: FitResult | None = None
        """The good fit of the frame before the last, when that frame had one."""
        self.size: tuple[int, ...] = ()
        self.detections = 0
        self.roll = 0.0
        """Roll of the last good fit, radians (kept after the face is lost)."""
        self._side = 1.0

    def reset(self) -> None:
        """Forget the last fit and its roll: the next frame starts from a detection."""
        self.last = self.before = None
        self.roll = 0.0
        self.misses = 0
        self._since = 0

    def track(self, image: np.ndarray) -> FitResult | None:
        """Fit ``image``; None when no face is found.

        A failed fit from the previous frame's parameters triggers a
        detection on the same frame (thesis section 7.2.2); so does a frame of
        another size than the last (the last fit says nothing of it). The face
        is looked for upright and in the frame turned by the last good fit's
        roll (or by +-:data:`SEARCH_DEG`, in turn), so that a rolled face is
        found again, on the frames and in the ways :attr:`search` picks. A
        failed fit from a detection is returned but not tracked from: the next
        frame detects again.

        Raises
        ------
        ValueError
            For something that is not an image array.
        """
        if new_size(image, self.size):
            self.size = image.shape[:2]
            self.reset()
        if self.last is not None:
            result = self.follow(image)
            if result.ok:
                return result
        upright, turned = self.search.passes(self.misses)
        angles = [0.0] * upright + [self._turn()] * turned
        self.detections += bool(angles)
        found = None
        for angle in angles:
            result = self._detect_and_fit(image, angle)
            if result is not None and result.ok:
                return self._keep(result)
            found = found or result
        self.last = self.before = None
        self.misses += 1
        return found

    def follow(self, image: np.ndarray) -> FitResult:
        """The fit of ``image`` from the last good fit (tracking and its refits), kept as the
        last one when it is good; no search. Needs a last fit (:meth:`adopt`)."""
        if self.last is None:
            raise ValueError("no face to follow: adopt a fit first")
        result = self._track(image, self.last)
        if not self.refit.never and self.fitter.quality is not None:
            result = self._refitted(image, result, self.last)
        return self._keep(result) if result.ok else result

    def adopt(self, result: FitResult, size: tuple[int, ...]) -> None:
        """Follow the face of a good fit ``result`` of a frame of ``size`` (``shape[:2]``) from
        the next frame on (a face found by another search than this tracker's)."""
        self.reset()
        self.size = size
        self._keep(result)

    def _track(self, image: np.ndarray, last: FitResult) -> FitResult:
        """The fit from the last frame's, moved on as the face moved between the two frames
        before (a fast face outruns a start from where it was), else from where it was."""
        if self.before is None or not _moving(self.before, last):
            return self.fitter.track(image, last)
        motion = last.similarity @ self.before.similarity.inverse()
        result = self.fitter.track(image, mapped(last, motion))
        return result if result.ok else self.fitter.track(image, last)

    def _refitted(self, image: np.ndarray, tracked: FitResult, last: FitResult) -> FitResult:
        """``tracked``, or the fit from the mean face placed on its landmarks (on the last
        fit's where tracking failed) where :attr:`refit` asks for one and it scores better."""
        policy = self.refit
        self._since += 1
        if tracked.ok:
            step = np.linalg.norm(centroid(tracked.points) - centroid(last.points))
            due = ((policy.every > 0 and self._since >= policy.every)
                   or tracked.score > policy.score
                   or tracked.disagreement > policy.disagreement
                   or step > policy.moving * np.ptp(last.points[:, 0]))
        else:
            due = policy.failed
        if not due:
            return tracked
        self._since = 0
        self.refits += 1
        refit = fit_upright(self.fitter, image, (tracked if tracked.ok else last).points)
        if not refit.ok or (tracked.ok and not refit.score < tracked.score):
            return tracked
        self.kept += 1
        if policy.then_track:
            polished = self.fitter.track(image, refit)
            if polished.ok and polished.score <= refit.score:
                return polished
        return refit

    def _keep(self, result: FitResult) -> FitResult:
        self.before, self.last, self.roll = self.last, result, roll_of(result)
        self.misses = 0
        return result

    def _turn(self) -> float:
        """The angle to turn the frame by in a search besides upright."""
        angle, self._side = turn_for_search(self.roll, self._side)
        return angle

    def _detect_and_fit(self, image: np.ndarray, angle: float) -> FitResult | None:
        """The fit from the largest face found in ``image`` turned by ``-angle``; None when
        there is none."""
        if angle == 0.0:
            boxes = self.detector.detect(image)
            return self.fitter.fit_box(image, boxes[0]) if len(boxes) else None
        # The search turns the grey frame (a third of the bytes); only a face found turns
        # the frame itself, to be fitted.
        grey = to_grey_uint8(image)
        boxes = self.detector.detect(rotated_view(grey, angle)[0])
        if len(boxes) == 0:
            return None
        view, to_view = rotated_view(image, angle)
        return mapped(self.fitter.fit_box(view, boxes[0]), to_view.inverse())


def turn_for_search(roll: float, side: float) -> tuple[float, float]:
    """The angle (radians) to turn the frame by in a search besides upright, and the side
    to turn to next time: the last good fit's ``roll`` when it is past :data:`TURN_DEG`,
    else :data:`SEARCH_DEG` to the other ``side`` (+1 or -1) than last time."""
    if abs(roll) > math.radians(TURN_DEG):
        return roll, side
    return -side * math.radians(SEARCH_DEG), -side


def new_size(image: np.ndarray, size: tuple[int, ...]) -> bool:
    """Whether ``image`` is of another size than ``size`` (``shape[:2]``: a tracker's last
    frame's, whose fit says nothing of it).

    Raises
    ------
    ValueError
        For something that is not an image array.
    """
    if not isinstance(image, np.ndarray) or image.ndim not in (2, 3) or image.size == 0:
        raise ValueError(f"not an image: {type(image).__name__} "
                         f"{getattr(image, 'shape', '')}")
    return image.shape[:2] != size


def fit_upright(fitter: Fitter, image: np.ndarray, shape: np.ndarray) -> FitResult:
    """The fit from the mean face placed on ``shape`` (N, 2), in the frame turned upright about
    the face where the placement rolls it more than :data:`UPRIGHT_DEG`."""
    _, start = fitter.aam.shape.fit_points(shape, iterations=1)
    roll = start.angle
    if not math.isfinite(roll) or abs(roll) <= math.radians(UPRIGHT_DEG):
        return fitter.fit_shape(image, shape)
    view, to_view = rotated_view(image, roll, shape.mean(axis=0))
    return mapped(fitter.fit_shape(view, to_view.apply(shape)), to_view.inverse())


def _moving(before: FitResult, last: FitResult) -> bool:
    """Whether the face moved more than :data:`MOVING` of its width from ``before`` to
    ``last``."""
    step = np.linalg.norm(centroid(last.points) - centroid(before.points))
    return bool(step > MOVING * np.ptp(last.points[:, 0]))
