"""What a fit returns: a landmark regressor's result, or an AAM fit with its appearance.

As menpofit separates fitters without a parametric appearance from those with
one, a fit is one of two types:

- :class:`LandmarkFit`: landmarks, their placement, the failure verdict, a
  quality score and a confidence: what a landmark regressor (``local-binary``)
  finds without sampling the face's texture;
- :class:`AAMFit`: the same and the AAM's appearance of the face: the
  combined parameters ``c``, the per-pixel texture residual, the texture error
  and the iterations the AAM took (none when the appearance was only projected
  at a regressor's landmarks). Per-landmark occlusion flags come from the
  residual where the model learned how to read it.

A fit is a value: frozen once made. What the fitter learns of it afterwards (its
verdict, its appearance, a refinement) makes a new fit (:func:`dataclasses.replace`),
each with the score of its own landmarks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

import numpy as np

from aamcore.model.similarity import Similarity


@dataclass(frozen=True)
class LandmarkFit:
    """Landmarks found in one image, and whether the fit failed.

    Attributes
    ----------
    points : (N, 2) array
        Fitted landmarks in image pixels.
    similarity : Similarity
        Placement of the model frame in the image (the AAM's pose ``t`` is
        ``similarity.params``).
    failed : bool
        True when the failure test rejected the fit (see
        :class:`~aamcore.fitting.failure.FailureTest`).
    reason : str
        Why the fit failed, empty otherwise.
    confidence : float
        How much the fit looks like a face, 0 to 1 (set by the fitter's failure test).
    score : float
        The learned fit-quality score, the predicted ``log(NME)`` of the landmarks
        (:class:`~aamcore.fitting.failure.QualityTest`); NaN where none was computed.
    seconds : list of float
        Time each stage (a regressor) or iteration (the AAM) took.
    disagreement : float
        How far apart the two fits a tracking step averaged lay (from the last landmarks,
        and afresh from the mean face placed on them): their mean point distance over the
        face's eye distance; a cue of failure. NaN where the fit is not such a mean.
    """

    points: np.ndarray
    similarity: Similarity
    failed: bool = False
    reason: str = ""
    confidence: float = math.nan
    score: float = math.nan
    seconds: list[float] = field(default_factory=list)
    disagreement: float = math.nan

    @property
    def ok(self) -> bool:
        return not self.failed


@dataclass(frozen=True, kw_only=True)
class AAMFit(LandmarkFit):
    """A fit with the AAM's appearance of the face.

    Attributes
    ----------
    c : (t_c,) array
        Combined appearance parameters.
    residual : (M,) float32 array
        The texture residual ``g_image - g_model(c)`` of each reference-frame
        pixel (eq. 6.19, in the units of the normalised texture; the mean over
        the channels of a colour model).
    error : float
        Texture error, the mean squared residual over every sample (eq. 7.7).
    iterations : int
        AAM iterations done (0: the appearance was projected at given landmarks).
    converged : bool
        Whether the algorithm stopped by its own convergence test rather than
        its iteration limit (a learned cascade and a projection always count as
        converged).
    errors : list of float
        Texture error after each iteration.
    occluded : (N,) bool array or None
        Per landmark, whether the texture around it says it is covered
        (:class:`~aamcore.fitting.occlusion.OcclusionTest`); None where not judged.
    texture : (M C,) float32 array or None
        The normalised texture sampled, where the fitter kept it (``residual`` plus the
        model texture of ``c``).
    """

    c: np.ndarray
    residual: np.ndarray
    error: float
    iterations: int = 0
    converged: bool = True
    errors: list[float] = field(default_factory=list)
    occluded: np.ndarray | None = None
    texture: np.ndarray | None = None

    @classmethod
    def of_landmarks(cls, fit: LandmarkFit, c: np.ndarray, residual: np.ndarray,
                     error: float, **more: object) -> AAMFit:
        """``fit`` with the appearance projected at its landmarks (no AAM iteration)."""
        kept = {f.name: getattr(fit, f.name) for f in fields(LandmarkFit)}
        kept["seconds"] = list(fit.seconds)
        return cls(**kept, c=c, residual=residual, error=error, **more)  # type: ignore[arg-type]


FitResult = LandmarkFit | AAMFit
"""Either kind of fit (an :class:`AAMFit` is a :class:`LandmarkFit`)."""


def judged(fit: FitResult, reason: str) -> FitResult:
    """``fit`` failed for ``reason`` (a new fit), or ``fit`` itself when there is none."""
    return replace(fit, failed=True, reason=reason) if reason else fit


def appearance_of(fit: LandmarkFit | None) -> np.ndarray | None:
    """The appearance ``c`` of a fit, None for a fit without one (or no fit)."""
    return fit.c if isinstance(fit, AAMFit) else None
