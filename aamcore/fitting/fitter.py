"""The fitter: a fitting model and one algorithm, started from a box, a shape or parameters."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from aamcore.fitting.algorithm import REGRESSORS, make_algorithm
from aamcore.fitting.algorithm.base import AlgorithmSettings
from aamcore.fitting.appearance import AppearanceSampler
from aamcore.fitting.config import FITTER, FitterConfig
from aamcore.fitting.failure import APPEARANCE_TESTS, FailureTest, QualityTest
from aamcore.fitting.model import FittingModel
from aamcore.fitting.occlusion import OcclusionTest
from aamcore.fitting.residuals import WarpFn
from aamcore.fitting.result import AAMFit, FitResult, LandmarkFit, judged
from aamcore.model.similarity import Similarity

NO_APPEARANCE = np.zeros(0)


def failure_kind(failure_test: str, algorithm: str) -> str:
    """The failure test ``auto`` stands for with ``algorithm``: ``quality`` for a landmark
    regressor, ``chi2`` for the AAM methods; any other name as it is."""
    if failure_test != "auto":
        return failure_test
    return "quality" if algorithm in REGRESSORS else "chi2"


class Fitter:
    """Fit one model with one algorithm, and judge the fit once.

    The algorithm finds the landmarks (and, for an AAM method, the appearance);
    the fitter then applies its one failure test, gives a good regressor's fit
    the AAM's appearance (:class:`~aamcore.fitting.appearance.AppearanceSampler`),
    refines it if asked, and flags occluded landmarks. Each of these makes a new fit
    (fits are values); a refined fit is scored and judged at its own landmarks.

    Parameters
    ----------
    model : FittingModel
    config : FitterConfig or str, optional
        The fitting's choices (:data:`~aamcore.fitting.config.FITTER` by default), or just
        the algorithm's name.
    warp : callable, optional
        Texture sampler ``warp(image, shape) -> (M, C)``; the CPU warp by default.
    **settings
        Fields of :class:`~aamcore.fitting.config.FitterConfig` to change
        (``Fitter(model, refine=3)``).

    Raises
    ------
    ValueError
        For an unknown algorithm or test, or a model without what they need
        (:class:`~aamcore.settings.ConfigError` for a setting it does not accept).
    """

    def __init__(self, model: FittingModel, config: FitterConfig | str = FITTER,
                 warp: WarpFn | None = None, **settings: object) -> None:
        if isinstance(config, str):
            settings = {"algorithm": config, **settings}
            config = FITTER
        config = config.with_values(**settings) if settings else config
        self.config = config
        self.model = model
        self.aam = model.aam
        self.mapping = model.mapping
        algorithm = config.algorithm
        self.failure_test = failure_kind(config.failure_test, algorithm)
        self.failure = FailureTest(self.aam.combined.pca.variances, self.failure_test)
        self.algorithm = make_algorithm(algorithm, model,
                                        AlgorithmSettings(warp, config.max_iterations))
        self.quality: QualityTest | None = None
        self.scorer = None
        if self.failure_test == "quality":
            self.scorer = self._scorer(model)
            self.quality = QualityTest(model.binary.threshold)  # type: ignore[union-attr]
        regressor = algorithm in REGRESSORS
        self.regressor = regressor
        sample = regressor and (config.appearance or config.refine > 0
                                or self.failure_test in APPEARANCE_TESTS)
        judged_here = (config.judges_occlusion and model.occlusion is not None
                       and (sample or not regressor))
        test = OcclusionTest(model.occlusion, self.aam) if judged_here else None
        self.sampler = AppearanceSampler(self.aam, test, warp) if sample else None
        # flags where the algorithm leaves an appearance of its own: the sampler's pass
        self.occlusion = (self.sampler or AppearanceSampler(self.aam, test, warp)) if test else None
        self._grey = getattr(self.algorithm, "grey_region", lambda image: None)
        self.refiner = None
        self.refine = config.refine
        if regressor and config.refine > 0:
            self.refiner = make_algorithm(config.refine_with, model,
                                          AlgorithmSettings(warp, config.refine))
        self.zero = np.zeros(self.aam.n_appearance)

    @classmethod
    def from_config(cls, model: FittingModel, config: FitterConfig,
                    warp: WarpFn | None = None) -> Fitter:
        """The fitter ``config`` describes."""
        return cls(model, config, warp)

    def _scorer(self, model: FittingModel):
        """What scores fits for the quality test: the algorithm itself if it is the
        local-binary method, else one built from the model's cascade."""
        from aamcore.fitting.algorithm.local_binary import LocalBinary

        if isinstance(self.algorithm, LocalBinary):
            return self.algorithm
        return LocalBinary.from_model(model, AlgorithmSettings())

    @property
    def name(self) -> str:
        return self.algorithm.name

    @property
    def warps(self) -> bool:
        """Whether fitting samples textures: an AAM method, or a regressor whose good fits
        get the AAM's appearance."""
        return self.sampler is not None or not self.regressor

    def prepare(self, image: np.ndarray, shape: np.ndarray | None = None) -> np.ndarray:
        """Convert an input image for the algorithm (channels, equalisation near ``shape``)."""
        prepare = getattr(self.algorithm, "prepare", None)
        return prepare(image, shape) if prepare else self.aam.prepare_image(image, shape)

    def fit(self, image: np.ndarray, c0: np.ndarray, start: Similarity) -> LandmarkFit:
        """Fit from appearance ``c0`` placed by ``start``."""
        shape = self.aam.shape_instance(c0, start)
        return self._rated(self.algorithm.run(self.prepare(image, shape), c0, start), image)

    def track(self, image: np.ndarray, previous: LandmarkFit) -> LandmarkFit:
        """Fit from the previous frame's fit (the algorithm chooses how to start from it)."""
        prepared = self.prepare(image, previous.points)
        return self._rated(self.algorithm.track(prepared, previous), image)

    def _rated(self, fit: FitResult, image: np.ndarray) -> FitResult:
        """``fit`` judged by the failure test, with its appearance (sampled where the
        algorithm has none, and refined if asked), its occlusion flags and confidence."""
        if fit.ok and self.quality is not None:
            fit = self._scored(fit, image)
        if fit.ok and self.sampler is not None and not isinstance(fit, AAMFit):
            fit = self._appearance(fit, image)
        if isinstance(fit, AAMFit) and fit.ok:
            if self.failure_test in APPEARANCE_TESTS:
                fit = judged(fit, self.failure(fit.c, fit.points))
            if fit.ok and self.occlusion is not None and fit.occluded is None:
                found = self.occlusion.project_frame(image, fit.points)
                fit = replace(fit, occluded=found.occluded)
        return replace(fit, confidence=self._confidence(fit))

    def _confidence(self, fit: FitResult) -> float:
        if fit.failed:
            return 0.0
        if self.quality is not None:
            return self.quality.confidence(fit.score)
        return self.failure.confidence(fit.c) if isinstance(fit, AAMFit) else 0.0

    def _scored(self, fit: FitResult, image: np.ndarray) -> FitResult:
        """``fit`` with the learned quality score of its landmarks (computed where the
        algorithm gave none), failed where the quality test says so."""
        if math.isnan(fit.score) and self.scorer is not None:
            fit = replace(fit, score=self.scorer.score(self.scorer.prepare(image), fit.points))
        c = fit.c if isinstance(fit, AAMFit) else NO_APPEARANCE
        return judged(fit, self.failure(c, fit.points)
                      or self.quality.reason(fit.score))  # type: ignore[union-attr]

    def _appearance(self, fit: LandmarkFit, image: np.ndarray) -> AAMFit:
        """A regressor's good ``fit`` with the AAM's appearance at its landmarks; refined by
        the AAM where asked, and then the refined fit, scored and judged at its own
        landmarks, where it passes."""
        assert self.sampler is not None
        found = self.sampler.project_frame(image, fit.points, self._grey(image))
        sampled = AAMFit.of_landmarks(fit, found.c, found.residual, found.error,
                                      errors=[found.error], texture=found.texture,
                                      occluded=found.occluded)
        if self.refiner is None or not np.all(np.isfinite(found.c)):
            return sampled
        prepared = self.aam.prepare_image(image, fit.points)  # the AAM may leave the box
        if hasattr(self.refiner, "refine"):  # the cascade's last stages, from the landmarks
            refined = self.refiner.refine(prepared, fit.points, self.refine)
        else:  # the AAM's iterations from the appearance projected at the landmarks
            refined = self.refiner.run(prepared, found.c, found.similarity)
        if refined.failed:
            return sampled
        refined = replace(refined, score=math.nan, seconds=fit.seconds + refined.seconds,
                          disagreement=fit.disagreement)
        if self.quality is not None:
            refined = self._scored(refined, image)
        return refined if refined.ok else sampled

    def fit_shape(self, image: np.ndarray, shape: np.ndarray) -> LandmarkFit:
        """Fit from the mean face placed on a start ``shape`` (N, 2)."""
        if not np.all(np.isfinite(shape)):
            raise ValueError("start shape has NaN or infinite coordinates")
        _, start = self.aam.shape.fit_points(shape, iterations=1)
        return self.fit(image, self.zero, start)

    def fit_box(self, image: np.ndarray, box: np.ndarray, source: str = "detector"
                ) -> LandmarkFit:
        """Fit from a face box ``(x, y, w, h)`` through the learned mapping."""
        box = np.asarray(box, dtype=np.float64).reshape(4)
        if not np.all(np.isfinite(box)) or box[2] <= 1 or box[3] <= 1:
            raise ValueError(f"invalid face box {box.tolist()}")
        return self.fit_shape(image, self.mapping.place(box, source))

