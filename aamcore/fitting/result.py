"""What a fit returns."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from aamcore.model.similarity import Similarity


@dataclass
class FitResult:
    """The outcome of fitting an AAM to one image.

    Attributes
    ----------
    points : (N, 2) array
        Fitted landmarks in image pixels.
    c : (t_c,) array
        Appearance parameters.
    similarity : Similarity
        Placement of the model frame in the image (the AAM's pose ``t`` is
        ``similarity.params``).
    error : float
        Final texture error, mean squared normalised residual (eq. 7.7).
    iterations : int
    converged : bool
        Whether the algorithm stopped by its own convergence test rather than
        its iteration limit (a learned cascade always runs all its stages).
    failed : bool
        True when the failure test rejected the fit (see
        :class:`~aamcore.fitting.failure.FailureTest`).
    reason : str
        Why the fit failed, empty otherwise.
    iteration_seconds : list of float
        Time each iteration took.
    errors : list of float
        Texture error after each iteration.
    confidence : float
        How much the fit looks like a face, 0 to 1 (set by the fitter's failure test).
    score : float
        The learned fit-quality score, the predicted ``log(NME)`` of the landmarks
        (:class:`~aamcore.fitting.failure.QualityTest`); NaN where none was computed.

    Notes
    -----
    Methods that compute no AAM appearance (``local-binary``) leave ``c`` empty,
    shape ``(0,)``, unless the fitter is asked to sample it.
    """

    points: np.ndarray
    c: np.ndarray
    similarity: Similarity
    error: float
    iterations: int
    converged: bool = True
    failed: bool = False
    reason: str = ""
    iteration_seconds: list[float] = field(default_factory=list)
    errors: list[float] = field(default_factory=list)
    confidence: float = math.nan
    score: float = math.nan

    @property
    def ok(self) -> bool:
        return not self.failed
