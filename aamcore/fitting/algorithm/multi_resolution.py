"""Multi-resolution fitting over an image pyramid (beyond the thesis).

Level ``l`` of the pyramid halves the image ``l`` times (``cv2.pyrDown``).
The reference frame does not change, so at coarse levels the model sees a
blurred face: a smoother cost with a wider basin of convergence. Each level
has its own update matrix, learned on training images at that level, and the
fit runs from the coarsest level to the full image, each level starting from
the one before.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from aamcore.fitting.algorithm.base import AlgorithmSettings
from aamcore.fitting.algorithm.fixed_jacobian import FixedJacobian
from aamcore.fitting.pyramid import pyramid
from aamcore.fitting.result import AAMFit, LandmarkFit
from aamcore.model.similarity import Similarity

if TYPE_CHECKING:
    from aamcore.fitting.model import FittingModel


def scale_similarity(similarity: Similarity, factor: float) -> Similarity:
    """The same placement in an image scaled by ``factor`` with ``cv2.pyrDown``'s convention.

    ``pyrDown`` keeps pixel centres aligned at ``x_small = (x + 0.5) / 2 - 0.5``
    for ``factor = 0.5``; the translation follows that convention.
    """
    offset = 0.5 * (factor - 1.0)
    s = similarity.scaled(factor)
    return Similarity(s.a, s.b, s.tx + offset, s.ty + offset)


class MultiResolution:
    """Run one fixed-Jacobian fitter per pyramid level, coarse to fine.

    Parameters
    ----------
    levels : list of FixedJacobian
        ``levels[l]`` fits images halved ``l`` times.
    """

    def __init__(self, levels: list[FixedJacobian]) -> None:
        if not levels:
            raise ValueError("a multi-resolution fitter needs at least one level")
        self.levels = levels
        self.name = f"multi-resolution({levels[0].name}, {len(levels)} levels)"

    @classmethod
    def from_model(cls, model: FittingModel, settings: AlgorithmSettings) -> MultiResolution:
        """One level per update matrix the model learned."""
        return cls([FixedJacobian.from_model(model, settings, level)
                    for level in range(len(model.updates))])

    def prepare(self, image: np.ndarray, shape: np.ndarray | None = None) -> np.ndarray:
        """As the full-resolution level prepares it."""
        return self.levels[0].prepare(image, shape)

    def track(self, image: np.ndarray, previous: LandmarkFit) -> AAMFit:
        """Fit from the previous frame's fit, at full resolution only."""
        return self.levels[0].track(image, previous)

    def run(self, image: np.ndarray, c0: np.ndarray, start: Similarity) -> AAMFit:
        """Fit from ``(c0, start)``, given in full-image pixels."""
        images = pyramid(image, len(self.levels))
        c, sim = c0, start
        seconds: list[float] = []
        errors: list[float] = []
        iterations = 0
        result = None
        for level in reversed(range(len(self.levels))):
            factor = 0.5**level
            result = self.levels[level].run(images[level], c, scale_similarity(sim, factor))
            c, sim = result.c, scale_similarity(result.similarity, 1.0 / factor)
            seconds += result.seconds
            errors += result.errors
            iterations += result.iterations
        assert result is not None
        result = replace(result, similarity=sim)
        if len(self.levels) > 1:
            # The coarse levels can also lead a near start astray: keep the
            # full-resolution fit from the start itself when it explains the
            # image better.
            direct = self.levels[0].run(image, c0, start)
            seconds += direct.seconds
            iterations += direct.iterations
            if direct.error < result.error:
                result = direct
        return replace(result, seconds=seconds, errors=errors, iterations=iterations)
