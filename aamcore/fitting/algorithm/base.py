"""What every fitting algorithm offers, and what it is built from."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from aamcore.fitting.failure import FailureTest
from aamcore.fitting.residuals import ResidualFunction, WarpFn
from aamcore.fitting.result import FitResult
from aamcore.model.aam import AAM
from aamcore.model.similarity import Similarity

if TYPE_CHECKING:
    from aamcore.fitting.model import FittingModel


@dataclass(frozen=True)
class AlgorithmSettings:
    """Run-time choices shared by the algorithms.

    Attributes
    ----------
    failure : FailureTest, optional
        How a failed fit is recognised (the thesis's eq. 7.2 by default).
    warp : callable, optional
        Texture sampler ``warp(image, shape) -> (M, C)``; the AAM's CPU warp
        by default (the GPU-warp worker offers the same call).
    max_iterations : int, optional
        Iteration limit of the iterative algorithms (each has its own default).
    """

    failure: FailureTest | None = None
    warp: WarpFn | None = None
    max_iterations: int | None = None


class ModelAlgorithm:
    """What the algorithms built on an AAM share: the model, its residual, the failure test.

    Parameters
    ----------
    aam : AAM
    settings : AlgorithmSettings, optional
    """

    computes_appearance = True

    def __init__(self, aam: AAM, settings: AlgorithmSettings | None = None) -> None:
        settings = settings or AlgorithmSettings()
        self.aam = aam
        self.residual = ResidualFunction(aam, settings.warp)
        self.failure = settings.failure or FailureTest(aam.combined.pca.variances)

    def prepare(self, image: np.ndarray, shape: np.ndarray | None = None) -> np.ndarray:
        """The AAM's channels, equalised near ``shape`` if the AAM says so."""
        return self.aam.prepare_image(image, shape)


class Algorithm(Protocol):
    """A fitting algorithm: costly precomputation in its constructor, per-frame work in
    :meth:`run` and :meth:`track`, both on an image prepared by its :meth:`prepare`.

    ``computes_appearance`` says whether its fits carry the AAM appearance ``c``
    (the AAM methods) or an empty ``(0,)`` one (``local-binary``).
    """

    name: str
    computes_appearance: bool

    def prepare(self, image: np.ndarray, shape: np.ndarray | None = None) -> np.ndarray:
        """Convert a raw frame (BGR or grey) into what :meth:`run` and :meth:`track` read."""
        ...

    @classmethod
    def from_model(cls, model: FittingModel, settings: AlgorithmSettings) -> Algorithm:
        """Build the algorithm from what the fitting model learned."""
        ...

    def run(self, image: np.ndarray, c0: np.ndarray, start: Similarity) -> FitResult:
        """Fit from appearance ``c0`` (t_c,) placed by ``start``."""
        ...

    def track(self, image: np.ndarray, previous: FitResult) -> FitResult:
        """Fit from the previous frame's fit, in whatever way suits the algorithm."""
        ...
