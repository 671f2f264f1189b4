"""The fitter: a fitting model and one algorithm, started from a box, a shape or parameters."""

from __future__ import annotations

import numpy as np

from aamcore import defaults
from aamcore.fitting.algorithm import make_algorithm
from aamcore.fitting.algorithm.base import AlgorithmSettings
from aamcore.fitting.failure import FailureTest
from aamcore.fitting.model import FittingModel
from aamcore.fitting.residuals import WarpFn
from aamcore.fitting.result import FitResult
from aamcore.model.similarity import Similarity


class Fitter:
    """Fit one AAM with one algorithm.

    Parameters
    ----------
    model : FittingModel
    algorithm : str
        A name of :data:`aamcore.fitting.algorithm.ALGORITHMS`.
    max_iterations : int, optional
    warp : callable, optional
        Texture sampler ``warp(image, shape) -> (M, C)``; the CPU warp by default.
    failure_test : {"eq7.2", "chi2"}
        How a failed fit is recognised (see :class:`FailureTest`).
    """

    def __init__(
        self,
        model: FittingModel,
        algorithm: str = defaults.ALGORITHM,
        max_iterations: int | None = None,
        warp: WarpFn | None = None,
        failure_test: str = defaults.FAILURE_TEST,
    ) -> None:
        self.model = model
        self.aam = model.aam
        self.mapping = model.mapping
        self.failure = FailureTest(self.aam.combined.pca.variances, failure_test)
        self.algorithm = make_algorithm(
            algorithm, model, AlgorithmSettings(self.failure, warp, max_iterations)
        )
        self.zero = np.zeros(self.aam.n_appearance)

    @property
    def name(self) -> str:
        return self.algorithm.name

    def prepare(self, image: np.ndarray, shape: np.ndarray | None = None) -> np.ndarray:
        """Convert an input image for the model (channels, equalisation near ``shape``)."""
        return self.aam.prepare_image(image, shape)

    def fit(self, image: np.ndarray, c0: np.ndarray, start: Similarity) -> FitResult:
        """Fit from appearance ``c0`` placed by ``start``."""
        shape = self.aam.shape_instance(c0, start)
        return self._rated(self.algorithm.run(self.prepare(image, shape), c0, start))

    def track(self, image: np.ndarray, previous: FitResult) -> FitResult:
        """Fit from the previous frame's fit (the algorithm chooses how to start from it)."""
        return self._rated(self.algorithm.track(self.prepare(image, previous.points), previous))

    def _rated(self, result: FitResult) -> FitResult:
        result.confidence = 0.0 if result.failed else self.failure.confidence(result.c)
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
