"""How the fitter fits: one options object for the library and the fitter service.

As MediaPipe's tasks take one options object, :class:`FitterConfig` holds
every choice of the fitting stage with its default, once: the library's
:class:`~aamcore.fitting.fitter.Fitter` and
:class:`~aamcore.tracker.FaceTracker` start from it, and the fitter service's
options (``services/fitter/options.py``) take their defaults from it.
"""

from __future__ import annotations

from dataclasses import dataclass

from aamcore import defaults


@dataclass(frozen=True)
class FitterConfig:
    """The fitting stage's choices.

    Attributes
    ----------
    algorithm : str
        A name of :data:`aamcore.fitting.algorithm.ALGORITHMS`.
    failure_test : str
        One of :data:`aamcore.fitting.failure.FAILURE_TESTS`.
    appearance : bool
        Give every good fit the AAM's appearance (an
        :class:`~aamcore.fitting.result.AAMFit`): a landmark regressor's fits are
        sampled into the reference frame and projected (one texture warp each).
        The AAM methods compute it whatever this says.
    occlusion : bool
        Judge per landmark whether the face there is covered, from the texture
        residual of the triangles around it (needs the appearance and a model
        with an occlusion part).
    refine : int
        After a regressor's landmarks, this many iterations of ``refine_with`` from
        them (0: none).
    refine_with : {"fixed-jacobian", "supervised-descent"}
        The AAM method that refines: the fixed-Jacobian update (Algorithm 7), or the
        last stages of the supervised-descent cascade.
    max_iterations : int or None
        Iteration limit of the iterative AAM methods (each has its own default).
    """

    algorithm: str = defaults.ALGORITHM
    failure_test: str = defaults.FAILURE_TEST
    appearance: bool = True
    occlusion: bool = True
    refine: int = 0
    refine_with: str = "fixed-jacobian"
    max_iterations: int | None = None


FITTER = FitterConfig()
"""The defaults."""
