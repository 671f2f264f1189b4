"""Multi-resolution fitting over an image pyramid (beyond the thesis).

Level ``l`` of the pyramid halves the image ``l`` times (``cv2.pyrDown``).
The reference frame does not change, so at coarse levels the model sees a
blurred face: a smoother cost with a wider basin of convergence. Each level
has its own update matrix, learned on training images at that level, and the
fit runs from the coarsest level to the full image, each level starting from
the one before.
"""

from __future__ import annotations

import numpy as np

from aamcore.fitting.pyramid import pyramid
from aamcore.fitting.result import FitResult


def scale_pose(t: np.ndarray, factor: float) -> np.ndarray:
    """Pose ``t`` (4,) of the same placement in an image scaled by ``factor``.

    ``pyrDown`` keeps pixel centres aligned at ``x_small = (x + 0.5) / 2 - 0.5``
    for ``factor = 0.5``; the translation follows that convention.
    """
    a = (1.0 + t[0]) * factor
    b = t[1] * factor
    offset = 0.5 * (factor - 1.0)
    return np.array([a - 1.0, b, t[2] * factor + offset, t[3] * factor + offset])


class MultiResolution:
    """Run one algorithm per pyramid level, coarse to fine.

    Parameters
    ----------
    levels : list of algorithms
        ``levels[l]`` fits images halved ``l`` times; each has
        ``run(image, c0, t0) -> FitResult``.
    """

    def __init__(self, levels: list) -> None:
        if not levels:
            raise ValueError("a multi-resolution fitter needs at least one level")
        self.levels = levels
        self.name = f"multi-resolution({levels[0].name}, {len(levels)} levels)"

    def track(self, image: np.ndarray, previous: FitResult) -> FitResult:
        """Fit from the previous frame's fit, at full resolution only."""
        return self.levels[0].track(image, previous)

    def run(self, image: np.ndarray, c0: np.ndarray, t0: np.ndarray) -> FitResult:
        """Fit from ``(c0, t0)``, given in full-image pixels."""
        images = pyramid(image, len(self.levels))
        c, t = c0, t0
        seconds: list[float] = []
        errors: list[float] = []
        iterations = 0
        result = None
        for level in reversed(range(len(self.levels))):
            factor = 0.5**level
            result = self.levels[level].run(images[level], c, scale_pose(t, factor))
            c, t = result.c, scale_pose(result.t, 1.0 / factor)
            seconds += result.iteration_seconds
            errors += result.errors
            iterations += result.iterations
        assert result is not None
        result.t = t
        if len(self.levels) > 1:
            # The coarse levels can also lead a near start astray: keep the
            # full-resolution fit from the start itself when it explains the
            # image better.
            direct = self.levels[0].run(image, c0, t0)
            seconds += direct.iteration_seconds
            iterations += direct.iterations
            if direct.error < result.error:
                result = direct
        result.iteration_seconds, result.errors, result.iterations = seconds, errors, iterations
        return result
