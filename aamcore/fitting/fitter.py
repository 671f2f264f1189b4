"""The fitter: a fitting model and one algorithm, started from a box, a shape or parameters."""

from __future__ import annotations

import math

import numpy as np

from aamcore import defaults
from aamcore.fitting.algorithm import algorithm_class, make_algorithm
from aamcore.fitting.algorithm.base import AlgorithmSettings
from aamcore.fitting.appearance import AppearanceSampler
from aamcore.fitting.failure import APPEARANCE_TESTS, FailureTest, QualityTest
from aamcore.fitting.model import FittingModel
from aamcore.fitting.residuals import WarpFn
from aamcore.fitting.result import FitResult
from aamcore.model.similarity import Similarity


def failure_kind(failure_test: str, algorithm: str) -> str:
    """The failure test ``auto`` stands for with ``algorithm``: ``quality`` for a method that
    computes no appearance, ``chi2`` for the AAM methods; any other name as it is."""
    if failure_test != "auto":
        return failure_test
    computes = getattr(algorithm_class(algorithm), "computes_appearance", True)
    return "chi2" if computes else "quality"


class Fitter:
    """Fit one model with one algorithm.

    Parameters
    ----------
    model : FittingModel
    algorithm : str
        A name of :data:`aamcore.fitting.algorithm.ALGORITHMS`.
    max_iterations : int, optional
    warp : callable, optional
        Texture sampler ``warp(image, shape) -> (M, C)``; the CPU warp by default.
    failure_test : {"auto", "chi2", "eq7.2", "quality"}
        How a failed fit is recognised (:class:`FailureTest`, :class:`QualityTest`;
        ``auto``: see :func:`failure_kind`).
    appearance : bool
        Sample the AAM appearance ``c`` of every good fit of a method that computes
        none (one texture warp per fit), for consumers of ``c``; a test of ``c``
        (``chi2``, ``eq7.2``) samples it whatever this says.

    Raises
    ------
    ValueError
        For an unknown algorithm or test, or a model without what they need.
    """

    def __init__(
        self,
        model: FittingModel,
        algorithm: str = defaults.ALGORITHM,
        max_iterations: int | None = None,
        warp: WarpFn | None = None,
        failure_test: str = defaults.FAILURE_TEST,
        appearance: bool = False,
    ) -> None:
        self.model = model
        self.aam = model.aam
        self.mapping = model.mapping
        self.failure_test = failure_kind(failure_test, algorithm)
        self.failure = FailureTest(self.aam.combined.pca.variances, self.failure_test)
        self.algorithm = make_algorithm(
            algorithm, model, AlgorithmSettings(self.failure, warp, max_iterations)
        )
        self.quality: QualityTest | None = None
        self.scorer = None
        if self.failure_test == "quality":
            self.scorer = self._scorer(model)
            self.quality = QualityTest(model.binary.threshold)  # type: ignore[union-attr]
        needs_c = appearance or self.failure_test in APPEARANCE_TESTS
        computes = getattr(self.algorithm, "computes_appearance", True)
        self.sampler = AppearanceSampler(self.aam, warp) if needs_c and not computes else None
        self.zero = np.zeros(self.aam.n_appearance)

    def _scorer(self, model: FittingModel):
        """What scores fits for the quality test: the algorithm itself if it is the
        local-binary method, else one built from the model's cascade."""
        from aamcore.fitting.algorithm.local_binary import LocalBinary

        if isinstance(self.algorithm, LocalBinary):
            return self.algorithm
        return LocalBinary.from_model(model, AlgorithmSettings(self.failure))

    @property
    def name(self) -> str:
        return self.algorithm.name

    def prepare(self, image: np.ndarray, shape: np.ndarray | None = None) -> np.ndarray:
        """Convert an input image for the algorithm (channels, equalisation near ``shape``)."""
        prepare = getattr(self.algorithm, "prepare", None)
        return prepare(image, shape) if prepare else self.aam.prepare_image(image, shape)

    def fit(self, image: np.ndarray, c0: np.ndarray, start: Similarity) -> FitResult:
        """Fit from appearance ``c0`` placed by ``start``."""
        shape = self.aam.shape_instance(c0, start)
        return self._rated(self.algorithm.run(self.prepare(image, shape), c0, start), image)

    def track(self, image: np.ndarray, previous: FitResult) -> FitResult:
        """Fit from the previous frame's fit (the algorithm chooses how to start from it)."""
        prepared = self.prepare(image, previous.points)
        return self._rated(self.algorithm.track(prepared, previous), image)

    def _rated(self, result: FitResult, image: np.ndarray) -> FitResult:
        """``result`` with its appearance (where sampled), its test and its confidence."""
        if self.quality is not None and self.scorer is not None:
            if math.isnan(result.score):
                result.score = self.scorer.score(self.scorer.prepare(image), result.points)
            if not result.failed:
                reason = self.quality.reason(result.score)
                result.failed, result.reason = bool(reason), reason
        if self.sampler is not None and result.c.size == 0 and not result.failed:
            result.c, result.error = self.sampler(image, result.points)
            if self.failure_test in APPEARANCE_TESTS:
                reason = self.failure(result.c, result.points)
                result.failed, result.reason = bool(reason), reason
        if result.failed:
            result.confidence = 0.0
        elif self.quality is not None:
            result.confidence = self.quality.confidence(result.score)
        else:
            result.confidence = self.failure.confidence(result.c)
        return result

    def fit_shape(self, image: np.ndarray, shape: np.ndarray) -> FitResult:
        """Fit from the mean face placed on a start ``shape`` (N, 2)."""
        if not np.all(np.isfinite(shape)):
            raise ValueError("start shape has NaN or infinite coordinates")
        _, start = self.aam.shape.fit_points(shape, iterations=1)
        return self.fit(image, self.zero, start)

    def fit_box(self, image: np.ndarray, box: np.ndarray, source: str = "detector") -> FitResult:
        """Fit from a face box ``(x, y, w, h)`` through the learned mapping."""
        box = np.asarray(box, dtype=np.float64).reshape(4)
        if not np.all(np.isfinite(box)) or box[2] <= 1 or box[3] <= 1:
            raise ValueError(f"invalid face box {box.tolist()}")
        return self.fit_shape(image, self.mapping.place(box, source))
