"""The fitter: a trained AAM, what its algorithms learned, and one algorithm.

:func:`prepare_fitting` adds to a freshly trained AAM what fitting needs (the
box-to-shape mapping, the update matrices, the descent cascade) so that all is
saved in its model file; :class:`Fitter` then fits from a box, a start shape,
parameters or the previous frame's fit; :class:`Tracker` runs it frame to
frame with re-detection; :func:`fitting_model_path` trains and caches the
stack's model.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

from aamcore.detection.haar import HaarFaceDetector
from aamcore.detection.mapping import (
    BoxToShapeMapping,
    detect_all,
    fit_box_to_shape,
    match_detection,
)
from aamcore.fitting.algorithm import (
    FixedJacobian,
    MultiResolution,
    ProjectOutInverseCompositional,
    SupervisedDescent,
)
from aamcore.fitting.residuals import WarpFn
from aamcore.fitting.result import FailureTest, FitResult
from aamcore.fitting.training.descent import attach_cascade, stored_cascade, train_descent
from aamcore.fitting.training.update import (
    attach_update,
    scheme_for_level,
    stored_levels,
    stored_update,
    train_update,
)
from aamcore.io import FaceSample
from aamcore.model.aam import AAM
from aamcore.model.cache import cached_model
from aamcore.model.training import TrainConfig

ALGORITHMS = ("supervised-descent", "fixed-jacobian", "multi-resolution", "project-out-ic")


def prepare_fitting(
    aam: AAM,
    samples: list[FaceSample],
    method: str = "jacobian",
    max_images: int | None = 60,
    descent_stages: int = 5,
    pyramid_levels: int = 2,
    progress: Callable[[Iterable[FaceSample]], Iterable[FaceSample]] | None = None,
) -> AAM:
    """Train what fitting needs and attach it to ``aam``, to be saved with it.

    That is the box-to-shape mapping (from Haar detections on ``samples``),
    the update matrices of the fixed-Jacobian fitter (``method``, on at most
    ``max_images`` images, one per pyramid level) and the supervised-descent
    cascade.
    """
    detector = HaarFaceDetector()
    detections = detect_all(samples, detector)
    mapping = fit_box_to_shape(aam.shape.mean_shape, [s.points for s in samples], detections)
    aam.attachment_header["box_to_shape"] = mapping.to_json(include_reference=False)
    for level in range(pyramid_levels):
        level_scheme = scheme_for_level(level)
        update = train_update(
            aam, samples, method, level_scheme, max_images, level=level, progress=progress
        )
        attach_update(aam, update, level_scheme, level)
    boxes = []
    for found, sample in zip(detections, samples, strict=True):
        k = match_detection(found, sample.points)
        boxes.append(None if k is None else found[k])
    cascade = train_descent(aam, samples, boxes, mapping, stages=descent_stages)
    attach_cascade(aam, cascade)
    return aam


def stored_mapping(aam: AAM) -> BoxToShapeMapping:
    """The box-to-shape mapping stored with ``aam``."""
    data = aam.attachment_header.get("box_to_shape")
    if data is None:
        raise ValueError("this model has no box-to-shape mapping: train it with `--fit`")
    return BoxToShapeMapping.from_json(data, reference=aam.shape.mean_shape)


class Fitter:
    """Fit one AAM with one algorithm.

    Parameters
    ----------
    aam : AAM
        A model prepared by :func:`prepare_fitting`.
    algorithm : {"supervised-descent", "fixed-jacobian", "multi-resolution", "project-out-ic"}
        ``multi-resolution`` runs the fixed-Jacobian fitter over an image
        pyramid, one level per stored update matrix.
    max_iterations : int, optional
    warp : callable, optional
        Texture sampler ``warp(image, shape) -> (M, C)``; the CPU warp by default.
    failure_test : {"eq7.2", "chi2"}
        How a failed fit is recognised (see :class:`FailureTest`).
    """

    def __init__(
        self,
        aam: AAM,
        algorithm: str = "supervised-descent",
        max_iterations: int | None = None,
        warp: WarpFn | None = None,
        failure_test: str = "eq7.2",
    ) -> None:
        if algorithm not in ALGORITHMS:
            raise ValueError(f"unknown fitting algorithm {algorithm!r}: choose one of {ALGORITHMS}")
        self.aam = aam
        self.mapping = stored_mapping(aam)
        failure = FailureTest(aam.combined.pca.variances, failure_test)
        if algorithm == "supervised-descent":
            self.algorithm = SupervisedDescent(aam, stored_cascade(aam), warp, failure)
        elif algorithm == "fixed-jacobian":
            self.algorithm = FixedJacobian(
                aam, stored_update(aam), max_iterations or 20, warp, failure
            )
        elif algorithm == "multi-resolution":
            levels = [
                FixedJacobian(aam, stored_update(aam, level), max_iterations or 20, warp, failure)
                for level in range(stored_levels(aam))
            ]
            self.algorithm = MultiResolution(levels)
        else:
            self.algorithm = ProjectOutInverseCompositional(
                aam, max_iterations or 30, warp, failure
            )
        self.zero = np.zeros(aam.n_appearance)

    @property
    def name(self) -> str:
        return self.algorithm.name

    def prepare(self, image: np.ndarray, shape: np.ndarray | None = None) -> np.ndarray:
        """Convert an input image for the model (channels, equalisation near ``shape``)."""
        return self.aam.prepare_image(image, shape)

    def fit(self, image: np.ndarray, c0: np.ndarray, t0: np.ndarray) -> FitResult:
        """Fit from appearance ``c0`` and pose ``t0``."""
        start = self.aam.shape_instance(c0, t0)
        return self.algorithm.run(self.prepare(image, start), c0, t0)

    def track(self, image: np.ndarray, previous: FitResult) -> FitResult:
        """Fit from the previous frame's fit (the algorithm chooses how to start from it)."""
        return self.algorithm.track(self.prepare(image, previous.points), previous)

    def fit_shape(self, image: np.ndarray, shape: np.ndarray) -> FitResult:
        """Fit from the mean face placed on a start ``shape`` (N, 2)."""
        if not np.all(np.isfinite(shape)):
            raise ValueError("start shape has NaN or infinite coordinates")
        _, t0 = self.aam.shape.fit_points(shape, iterations=1)
        return self.fit(image, self.zero, t0)

    def fit_box(self, image: np.ndarray, box: np.ndarray, source: str = "detector") -> FitResult:
        """Fit from a face box ``(x, y, w, h)`` through the learned mapping."""
        box = np.asarray(box, dtype=np.float64).reshape(4)
        if not np.all(np.isfinite(box)) or box[2] <= 1 or box[3] <= 1:
            raise ValueError(f"invalid face box {box.tolist()}")
        return self.fit_shape(image, self.mapping.place(box, source))


class Tracker:
    """Track a face from frame to frame, re-detecting when there is none or a fit fails.

    Parameters
    ----------
    fitter : Fitter
    detector : HaarFaceDetector, optional
    """

    def __init__(self, fitter: Fitter, detector: HaarFaceDetector | None = None) -> None:
        self.fitter = fitter
        self.detector = detector or HaarFaceDetector()
        self.last: FitResult | None = None
        self.detections = 0

    def reset(self) -> None:
        """Forget the last fit: the next frame starts from a detection."""
        self.last = None

    def track(self, image: np.ndarray) -> FitResult | None:
        """Fit ``image``; None when no face is found.

        A failed fit from the previous frame's parameters triggers a
        detection on the same frame (thesis section 7.2.2).
        """
        if self.last is not None:
            result = self.fitter.track(image, self.last)
            if result.ok:
                self.last = result
                return result
        self.detections += 1
        boxes = self.detector.detect(image)
        if len(boxes) == 0:
            self.last = None
            return None
        result = self.fitter.fit_box(image, boxes[0])
        self.last = result if result.ok else None
        return result


def fitting_model_path(
    dataset: str = "lfpw",
    config: TrainConfig | None = None,
    max_images: int = 30,
    limit: int | None = None,
) -> Path:
    """Path of a cached model ready for fitting, trained on first use.

    Parameters
    ----------
    dataset : str
        Dataset name or folder (``lfpw`` gives the 68-point iBUG markup that
        the head-pose model expects).
    config : TrainConfig, optional
        Defaults to grey textures over about 10k reference pixels.
    max_images : int
        Images used to learn the update matrix.
    limit : int, optional
        Train on the first ``limit`` images only (small models for tests).
    """
    config = config or TrainConfig(colour=False, shape_variance=0.98)

    def select(samples: list[FaceSample]) -> list[FaceSample]:
        return samples[:limit] if limit else samples

    def prepare(aam: AAM, samples: list[FaceSample]) -> AAM:
        return prepare_fitting(aam, samples, max_images=max_images)

    return cached_model(
        dataset,
        config,
        select=select,
        select_name=f"first {limit}" if limit else "all",
        prepare=prepare,
        prepare_name=f"fitting v4, {max_images} images",
    )
