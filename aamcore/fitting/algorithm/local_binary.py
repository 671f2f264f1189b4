"""Cascaded regression on local binary features, in a shape space: the default tracker.

From a detection the start shape goes through coarse landmark-HOG stages
(:mod:`~aamcore.fitting.algorithm.local_hog`) and the fern stages
(:mod:`~aamcore.fitting.algorithm.ferns`); from the previous frame's landmarks, through the
fern stages. Where the cascade has restart stages, either fit is averaged with one made
afresh as dlib's tracker does (the mean shape placed on it, through the restart and fern
stages) and projected back onto the shape model: a tracked face keeps no error the
expression left on the last frame, and how far apart the two lay is the fit's
``disagreement`` (a cue of failure, ``bench/bench_failure_tests.py``). Every step is taken in
the basis of :class:`~aamcore.fitting.shape_space.ShapeSpace`, and every shape returned is
projected onto the shape model (3 sd). One more fern stage regresses the fit's ``log(NME)``
(its quality score); above the model's calibrated threshold the fit has failed.

The method reads the grey pixels of the face's region only and computes no AAM appearance:
it returns a :class:`~aamcore.fitting.result.LandmarkFit` with its quality score, and the
:class:`~aamcore.fitting.fitter.Fitter` applies the threshold and samples the appearance.
What it learned is a :class:`~aamcore.fitting.learned.BinaryCascade`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import cv2
import numpy as np

from aamcore.detection.haar import to_grey_uint8
from aamcore.fitting.algorithm.base import AlgorithmSettings
from aamcore.fitting.algorithm.ferns import FernRunner
from aamcore.fitting.algorithm.local_hog import LandmarkHog
from aamcore.fitting.appearance import GreyRegion
from aamcore.fitting.learned import BinaryCascade
from aamcore.fitting.result import LandmarkFit
from aamcore.model.aam import AAM
from aamcore.model.similarity import Placement, Similarity, centroid

if TYPE_CHECKING:
    from aamcore.fitting.model import FittingModel

MIN_CONTRAST = 8
"""Least spread (grey levels) of the pixels the quality stage reads for a fit to count:
a black, blank or saturated region holds no face."""
MIN_EYE_DISTANCE = 8.0
"""Least distance (pixels) between the outer eye corners of a fit that counts (held-out LFPW
faces shrunk: mean NME 0.22 at 4 px, 0.12 at 6, 0.08 at 8, 0.05 at 16; 20 faces)."""
MARGIN = 1.1
"""Region read around the shape, in stage radii (pixel pairs lie within a radius)."""


@dataclass
class _Region:
    """The grey pixels the stages read: flat uint8, ``width`` wide, ``origin`` in the frame."""

    pixels: np.ndarray
    width: int
    limit: tuple[float, float]
    origin: np.ndarray


class LocalBinary:
    """Fit by a :class:`BinaryCascade`.

    Parameters
    ----------
    cascade : BinaryCascade
    aam : AAM, optional
        Its mean shape gives the results' similarity (the AAM's model frame)
        and the start shape of :meth:`run`; the cascade's mean shape without one.
    settings : AlgorithmSettings, optional
        Nothing in them changes this method (it warps nothing and iterates no more
        than its stages).
    """

    name = "local-binary"

    def __init__(self, cascade: BinaryCascade, aam: AAM | None = None,
                 settings: AlgorithmSettings | None = None) -> None:
        self.cascade = cascade
        self.aam = aam
        space = cascade.space
        self.space = space
        self._frame = aam.shape.mean_shape if aam is not None else space.mean
        self._frame_place = Placement(self._frame)
        left, right = space.eye_corners
        self._frame_eyes = float(np.linalg.norm(self._frame[left] - self._frame[right]))
        self._mean = space.mean
        self._modes, self._modes_t = space.modes, np.ascontiguousarray(space.modes.T)
        self._mean_proj = space.mean.ravel() @ space.modes
        self._limits, self._neg_limits = space.limits, -space.limits
        self._basis_t = np.ascontiguousarray(space.basis.T)
        unit = space.eye_distance
        self._hogs = [LandmarkHog(space.mean, c.iod, c.window, c.cells, unit)
                      for c in cascade.coarse]
        self._ferns = [FernRunner(s) for s in cascade.tracking]
        self._restart = [FernRunner(s) for s in cascade.restart]
        self._quality = FernRunner(cascade.quality)
        self._reach = MARGIN * max(s.radius for s in [*cascade.tracking, *cascade.restart,
                                                      cascade.quality])

    @classmethod
    def from_model(cls, model: FittingModel, settings: AlgorithmSettings) -> LocalBinary:
        """The cascade ``model`` learned.

        Raises
        ------
        ValueError
            When the model has no local-binary cascade.
        """
        if model.binary is None:
            raise ValueError("this model has no local-binary cascade: train it with "
                             "`aamtrack train --fit` (68-point data)")
        return cls(model.binary, model.aam, settings)

    def prepare(self, image: np.ndarray, shape: np.ndarray | None = None) -> np.ndarray:
        """``image`` as the stages read it: uint8 BGR or grey (other inputs converted to grey).

        Raises
        ------
        ValueError
            When ``image`` holds no pixels.
        """
        if image.size == 0:
            raise ValueError(f"an image of shape {image.shape} holds no pixels")
        if image.dtype == np.uint8 and (image.ndim == 2 or (image.ndim == 3
                                                            and image.shape[2] == 3)):
            return image
        return to_grey_uint8(image)

    def run(self, image: np.ndarray, c0: np.ndarray, start: Similarity) -> LandmarkFit:
        """Fit from the mean shape of ``(c0, start)`` (the AAM's, if the model has one)."""
        if self.aam is not None:
            shape = self.aam.shape_instance(c0, start)
        else:
            shape = start.apply(self._frame)
        return self.fit_shape(image, shape)

    def track(self, image: np.ndarray, previous: LandmarkFit) -> LandmarkFit:
        """Fit from the previous frame's landmarks with the fern stages."""
        return self.track_points(image, previous.points)

    def fit_shape(self, image: np.ndarray, start: np.ndarray) -> LandmarkFit:
        """Fit from a start shape (N, 2) on a detection: coarse stages, then the fern stages
        and, where the cascade has restart stages, the mean of that fit and the restart from
        it (as :meth:`track_points` does from the previous frame's)."""
        start = np.asarray(start, np.float64)
        if not np.all(np.isfinite(start)):
            return self._failed(start, "non-finite start shape")
        seconds: list[float] = []
        points = self._detected(image, start, seconds)
        region = None if points is None else self.region(image, points)
        if points is None or region is None:
            return self._failed(start, "the face lies outside the frame", seconds)
        score, contrast = self._score(region, points - region.origin)
        return self._result(points, seconds, score, contrast)

    def _detected(self, image: np.ndarray, start: np.ndarray, seconds: list[float]
                  ) -> np.ndarray | None:
        """The landmarks (N, 2) from a detection's ``start`` (N, 2) through the coarse and
        fern stages and their mean with the restart from them (None: outside the frame)."""
        shape = self.project(start)
        for stage, hog in zip(self.cascade.coarse, self._hogs, strict=True):
            begun = time.perf_counter()
            a, b = self._ab(shape)
            move = (hog.step(stage, image, shape) @ self._basis_t).reshape(-1, 2)
            shape = self.project(shape + move @ np.array([[a, b], [-b, a]]))
            seconds.append(time.perf_counter() - begun)
        region = self.region(image, shape)
        if region is None:
            return None
        fitted = self._fern_shape(region, shape - region.origin, seconds) + region.origin
        if not self._restart:
            return fitted
        # as in tracking, the mean of that fit and the one afresh from the mean shape placed
        # on it, for one restart pass more per detection: two fits whose errors are little
        # correlated (bench_fit_lfpw.py, held out, mean NME: LFPW 0.0442 -> 0.0422, HELEN
        # 0.0402 -> 0.0388, AFW 0.0734 -> 0.0705; bench_tracking.py: 87.5 % of the rigid
        # frames outside the occluder tracked well instead of 84.2 %)
        region = self.region(image, fitted)
        if region is None:
            return None
        restarted = self._restart_shape(region, fitted, seconds) + region.origin
        return self.project(0.5 * (fitted + restarted))  # a face again, as in tracking

    def track_points(self, image: np.ndarray, previous: np.ndarray) -> LandmarkFit:
        """Fit from landmarks (N, 2) of the previous frame: the fern stages from them and,
        where the cascade has restart stages, the mean of that fit and the one afresh from
        the mean shape placed on them (:meth:`restart`), projected onto the shape model and
        scored there; how far apart the two lay is its ``disagreement``."""
        previous = np.asarray(previous, np.float64)
        if not np.all(np.isfinite(previous)):
            return self._failed(previous, "non-finite start shape")
        if not self._restart:
            return self._fern_fit(image, previous, [])
        # one region for both fits: it reaches as far as the restart stages read
        region = self.region(image, previous)
        if region is None:
            return self._failed(previous, "the face lies outside the frame")
        seconds: list[float] = []
        start = self.placed_mean(previous) - region.origin
        start = self.project(self._stages(region, start, self._restart, seconds))
        # both fits go through the fern stages together (one pass of each stage)
        both = self._paired_stages(region, np.stack([previous - region.origin, start]),
                                   seconds)
        tracked, restarted = self.project(both[0]), self.project(both[1])
        # two fits of one frame whose errors are little correlated: their mean is steadier
        # and closer than either, or than the better-scored one (bench_tracking.py,
        # bench_smoothing.py); a face again (the mean of two placed faces is not one) and
        # scored where it lies, so that a fit half on a lost branch is not passed on the
        # other's score
        current = self.project(0.5 * (tracked + restarted))
        score, contrast = self._score(region, current)
        fit = self._result(current + region.origin, seconds, score, contrast)
        apart = float(np.linalg.norm(tracked - restarted, axis=1).mean())
        return replace(fit, disagreement=apart / (math.hypot(*self._ab(current))
                                                  * self.space.eye_distance))

    def restart(self, image: np.ndarray, previous: np.ndarray) -> LandmarkFit:
        """Fit afresh from the mean shape placed on landmarks ``previous`` (N, 2): the restart
        stages, projection, the fern stages (only the placement of ``previous`` counts).

        Raises
        ------
        ValueError
            When the cascade has no restart stages.
        """
        if not self._restart:
            raise ValueError("this cascade has no restart stages")
        previous = np.asarray(previous, np.float64)
        region = self.region(image, previous)
        if region is None:
            return self._failed(self.placed_mean(previous), "the face lies outside the frame")
        seconds: list[float] = []
        current = self._restart_shape(region, previous, seconds)
        score, contrast = self._score(region, current)
        return self._result(current + region.origin, seconds, score, contrast)

    def placed_mean(self, shape: np.ndarray) -> np.ndarray:
        """The cascade's mean shape placed by the least-squares similarity on ``shape``
        (N, 2): where the restart stages start."""
        a, b = self._ab(shape)
        return self._mean @ np.array([[a, b], [-b, a]]) + centroid(shape)

    def score(self, image: np.ndarray, points: np.ndarray) -> float:
        """Quality score of landmarks ``points`` (N, 2): the predicted log NME (high: poor fit
        or no face; infinite where the region holds no contrast or lies outside ``image``)."""
        region = self.region(image, points)
        if region is None:
            return math.inf
        return self._score(region, points - region.origin)[0]

    def region(self, image: np.ndarray, shape: np.ndarray) -> _Region | None:
        """The grey region of ``image`` the stages read around ``shape`` (N, 2), None when it
        lies outside the frame."""
        reach = self._reach * math.hypot(*self._ab(shape))
        (xlo, ylo), (xhi, yhi) = shape.min(axis=0).tolist(), shape.max(axis=0).tolist()
        height, width = image.shape[:2]
        x0, y0 = max(math.floor(xlo - reach), 0), max(math.floor(ylo - reach), 0)
        x1, y1 = min(math.ceil(xhi + reach) + 1, width), min(math.ceil(yhi + reach) + 1, height)
        if x1 - x0 < 2 or y1 - y0 < 2:
            return None
        roi = image[y0:y1, x0:x1]
        if roi.ndim == 3:
            roi = cv2.cvtColor(roi, cv2.COLOR_BGR2GRAY)
        pixels = np.ascontiguousarray(roi).ravel()
        region = _Region(pixels, x1 - x0, (x1 - x0 - 1.0, y1 - y0 - 1.0),
                         np.array([x0, y0], dtype=np.float64))
        self._last = (image, region)
        return region

    def grey_region(self, image: np.ndarray) -> GreyRegion | None:
        """The grey part of ``image`` that the last fit read (the appearance samples it
        rather than convert the face again), None when the last fit read another image."""
        last = getattr(self, "_last", None)
        if last is None or last[0] is not image:
            return None
        region = last[1]
        x0, y0 = region.origin.tolist()
        return GreyRegion(region.pixels.reshape(-1, region.width), (int(x0), int(y0)))

    def project(self, shape: np.ndarray) -> np.ndarray:
        """``shape`` (N, 2) projected onto the shape model, parameters limited to 3 sd."""
        a, b = self._ab(shape)
        centre = centroid(shape)
        s2 = a * a + b * b
        model = (shape - centre) @ np.array([[a / s2, -b / s2], [b / s2, a / s2]])
        params = model.ravel() @ self._modes
        params -= self._mean_proj
        np.minimum(params, self._limits, out=params)
        np.maximum(params, self._neg_limits, out=params)
        fitted = (params @ self._modes_t).reshape(-1, 2)
        fitted += self._mean
        return fitted @ np.array([[a, b], [-b, a]]) + centre

    def _ab(self, shape: np.ndarray) -> tuple[float, float]:
        """``(a, b)`` of the mean shape's least-squares placement on ``shape`` (N, 2): the
        shape space's one :class:`~aamcore.model.similarity.Placement`."""
        a, b = self.space.similarity(shape).tolist()
        return a, b

    def eye_distance(self, shape: np.ndarray) -> float:
        """The outer eye corners' distance (pixels) of the model's shape placed on ``shape``
        (N, 2)."""
        return math.hypot(*self._ab(shape)) * self.space.eye_distance

    def _rot(self, shape: np.ndarray) -> np.ndarray:
        a, b = self._ab(shape)
        return np.array([[a, -b], [b, a]])

    def _fern_fit(self, image: np.ndarray, shape: np.ndarray, seconds: list[float]
                  ) -> LandmarkFit:
        """The fern stages from ``shape`` (N, 2), projection, quality score, result."""
        region = self.region(image, shape)
        if region is None:
            return self._failed(shape, "the face lies outside the frame", seconds)
        current = self._fern_shape(region, shape - region.origin, seconds)
        score, contrast = self._score(region, current)
        return self._result(current + region.origin, seconds, score, contrast)

    def _fern_shape(self, region: _Region, current: np.ndarray, seconds: list[float]
                    ) -> np.ndarray:
        """``current`` (N, 2, region pixels) through the fern stages, projected."""
        return self.project(self._stages(region, current, self._ferns, seconds))

    def _restart_shape(self, region: _Region, previous: np.ndarray, seconds: list[float]
                       ) -> np.ndarray:
        """The mean shape placed on ``previous`` (N, 2, image pixels) through the restart
        stages, projection and the fern stages (region pixels)."""
        start = self.placed_mean(previous) - region.origin
        current = self.project(self._stages(region, start, self._restart, seconds))
        return self._fern_shape(region, current, seconds)

    def _stages(self, region: _Region, current: np.ndarray, stages: list[FernRunner],
                seconds: list[float]) -> np.ndarray:
        """``current`` (N, 2, region pixels) moved by fern ``stages``, each one's time added
        to ``seconds``."""
        for runner in stages:
            begun = time.perf_counter()
            rot = self._rot(current)
            dq = runner.output(runner.values(region.pixels, region.width, region.limit,
                                             current, rot))
            current = current + (dq @ self._basis_t).reshape(-1, 2) @ rot.T
            seconds.append(time.perf_counter() - begun)
        return current

    def _paired_stages(self, region: _Region, shapes: np.ndarray, seconds: list[float]
                       ) -> np.ndarray:
        """:meth:`_stages` of the fern stages for several shapes (S, N, 2, region pixels) at
        once (the same steps to 1e-12 pixel)."""
        count = len(shapes)
        for runner in self._ferns:
            begun = time.perf_counter()
            a, b = self.space.similarity(shapes).T
            rots = np.empty((count, 2, 2))
            rots[:, 0, 0] = rots[:, 1, 1] = a
            rots[:, 0, 1], rots[:, 1, 0] = -b, b
            dq = runner.outputs(runner.values_of(region.pixels, region.width, region.limit,
                                                 shapes, rots))
            shapes = shapes + (dq @ self._basis_t).reshape(count, -1, 2) @ rots.transpose(
                0, 2, 1)
            seconds.append(time.perf_counter() - begun)
        return shapes

    def _score(self, region: _Region, shape: np.ndarray) -> tuple[float, int]:
        """Quality score at ``shape`` (region pixels) and the spread of the pixels it read."""
        values = self._quality.values(region.pixels, region.width, region.limit, shape,
                                      self._rot(shape))
        contrast = int(values.max()) - int(values.min())
        if contrast < MIN_CONTRAST:
            return math.inf, contrast
        return float(self._quality.output(values)[0]), contrast

    def _similarity(self, points: np.ndarray) -> Similarity:
        """Least-squares placement of the model frame's mean shape on ``points`` (N, 2)."""
        return self._frame_place.onto(points)

    def _result(self, points: np.ndarray, seconds: list[float], score: float, contrast: int
                ) -> LandmarkFit:
        reason, similarity = "", Similarity()
        if not np.all(np.isfinite(points)):
            reason = "non-finite shape"
        else:
            similarity = self._similarity(points)
            # the eye corners' distance from the placement the result carries: no extra cost
            eyes = math.hypot(similarity.a, similarity.b) * self._frame_eyes
            if eyes < MIN_EYE_DISTANCE:
                reason = (f"face too small: {eyes:.1f} px between the outer eye corners "
                          f"(at least {MIN_EYE_DISTANCE:g})")
            elif contrast < MIN_CONTRAST:
                reason = f"no contrast around the landmarks ({contrast} grey levels)"
        return LandmarkFit(points, similarity, bool(reason), reason,
                           0.0 if reason else math.nan, score, seconds)

    def _failed(self, shape: np.ndarray, reason: str, seconds: list[float] | None = None
                ) -> LandmarkFit:
        return LandmarkFit(np.asarray(shape, np.float64), Similarity(), True, reason, 0.0,
                           math.inf, seconds or [])
