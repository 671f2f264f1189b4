"""What every fitting algorithm offers, and what it is built from."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from aamcore.fitting.residuals import ResidualFunction, WarpFn, per_pixel
from aamcore.fitting.result import AAMFit, LandmarkFit
from aamcore.model.aam import AAM
from aamcore.model.similarity import Similarity

if TYPE_CHECKING:
    from aamcore.fitting.model import FittingModel


@dataclass(frozen=True)
class AlgorithmSettings:
    """Run-time choices shared by the algorithms.

    Attributes
    ----------
    warp : callable, optional
        Texture sampler ``warp(image, shape) -> (M, C)``; the AAM's CPU warp
        by default (the GPU-warp worker offers the same call).
    max_iterations : int, optional
        Iteration limit of the iterative algorithms (each has its own default).
    """

    warp: WarpFn | None = None
    max_iterations: int | None = None


class ModelAlgorithm:
    """What the algorithms built on an AAM share: the model and its residual.

    An algorithm reports what it found (an :class:`~aamcore.fitting.result.AAMFit`,
    failed only for what it cannot go on from: non-finite parameters); whether
    the fit has failed is the :class:`~aamcore.fitting.fitter.Fitter`'s test.

    Parameters
    ----------
    aam : AAM
    settings : AlgorithmSettings, optional
    """

    def __init__(self, aam: AAM, settings: AlgorithmSettings | None = None) -> None:
        settings = settings or AlgorithmSettings()
        self.aam = aam
        self.residual = ResidualFunction(aam, settings.warp)

    def result(self, points: np.ndarray, c: np.ndarray, similarity: Similarity,
               residual: np.ndarray, **more: object) -> AAMFit:
        """The fit of ``c`` placed by ``similarity`` at ``points`` (N, 2), with its texture
        ``residual`` (M C,); failed only where something is not finite."""
        finite = bool(np.all(np.isfinite(points)) and np.all(np.isfinite(c)))
        residual = per_pixel(residual, self.aam.channels)
        error = float(residual @ residual) / max(residual.size, 1) if finite else np.nan
        return AAMFit(points=points, similarity=similarity, failed=not finite,
                      reason="" if finite else "non-finite parameters", c=c,
                      residual=residual, error=error, **more)  # type: ignore[arg-type]

    def prepare(self, image: np.ndarray, shape: np.ndarray | None = None) -> np.ndarray:
        """The AAM's channels, equalised near ``shape`` if the AAM says so."""
        return self.aam.prepare_image(image, shape)


class Algorithm(Protocol):
    """A fitting algorithm: costly precomputation in its constructor, per-frame work in
    :meth:`run` and :meth:`track`, both on an image prepared by its :meth:`prepare`.

    The AAM methods return an :class:`~aamcore.fitting.result.AAMFit`, a
    landmark regressor (``local-binary``) a :class:`~aamcore.fitting.result.LandmarkFit`.
    """

    name: str

    def prepare(self, image: np.ndarray, shape: np.ndarray | None = None) -> np.ndarray:
        """Convert a raw frame (BGR or grey) into what :meth:`run` and :meth:`track` read."""
        ...

    @classmethod
    def from_model(cls, model: FittingModel, settings: AlgorithmSettings) -> Algorithm:
        """Build the algorithm from what the fitting model learned."""
        ...

    def run(self, image: np.ndarray, c0: np.ndarray, start: Similarity) -> LandmarkFit:
        """Fit from appearance ``c0`` (t_c,) placed by ``start``."""
        ...

    def track(self, image: np.ndarray, previous: LandmarkFit) -> LandmarkFit:
        """Fit from the previous frame's fit, in whatever way suits the algorithm."""
        ...
