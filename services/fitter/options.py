"""The fitter's options (see :mod:`services.bus.options`)."""

from __future__ import annotations

from dataclasses import dataclass

from aamcore import defaults
from aamcore.defaults import FAILURE_TESTS
from aamcore.fitting.algorithm import ALGORITHMS
from aamcore.fitting.config import FITTER, FitterConfig
from services.bus.options import Options, in_range, option

WARPS = ("auto", "gpu", "cpu")
UPDATE_METHODS = ("jacobian", "regression")
MAX_FACES = 64
"""As :data:`proto.messages.MAX_FACES` (a frame's fits count at most so many)."""
"""As :data:`aamcore.fitting.training.update.METHODS` (not imported: options load light)."""


@dataclass(frozen=True)
class FitterOptions(Options):
    """The fitting model, algorithm and warp, and how the detector is asked."""

    model: str | None = option(None, "fitting model file (default: the cached default model, "
                               "trained on first use)", metavar="FILE")
    model_limit: int = option(0, "train the default model on the first N images only "
                              "(small, for tests)", metavar="N", check=in_range(0))
    model_images: int = option(defaults.MODEL_UPDATE_IMAGES, "images for the default model's "
                               "update matrices", metavar="N", check=in_range(1, 10000))
    model_update: str = option("jacobian", "how the default model's update matrices are learned "
                               "(the fixed-Jacobian AAM's): jacobian (Algorithm 6) or regression "
                               "(Algorithm 5)", choices=UPDATE_METHODS)
    algorithm: str = option(FITTER.algorithm, "fitting algorithm", choices=tuple(ALGORITHMS))
    failure_test: str = option(FITTER.failure_test, "how a failed fit is recognised (auto: "
                               "the learned quality score for local-binary, chi2 for the AAM "
                               "methods)", choices=FAILURE_TESTS)
    appearance: bool = option(FITTER.appearance, "give every good fit the AAM's appearance "
                              "(c, texture residual, occlusion flags): a landmark regressor's "
                              "fits (local-binary) are sampled and projected, one texture warp "
                              "each")
    occlusion: bool = option(FITTER.occlusion, "flag the landmarks whose part of the face is "
                             "covered, from the texture residual around them")
    refine: int = option(FITTER.refine, "after a regressor's landmarks, this many iterations "
                         "of --refine-with (0: none)", metavar="N", check=in_range(0, 100))
    refine_with: str = option(FITTER.refine_with, "the AAM method that refines: the "
                              "fixed-Jacobian update, or the supervised-descent cascade's last "
                              "stages", choices=("fixed-jacobian", "supervised-descent"))
    warp: str = option("auto", "where the image warp runs: auto (the GPU worker thread on a "
                       "hardware GL renderer, else the CPU), gpu (falls back to cpu) or cpu",
                       choices=WARPS)
    detect_timeout: float = option(1.0, "seconds to wait for the detector service",
                                   check=in_range(0.01, 60))
    local_for: float = option(5.0, "seconds to detect locally after the service did not answer",
                              check=in_range(0))
    capacity: int = option(2, "latest frames kept while busy (older ones are dropped)",
                           check=in_range(1, 1024))
    smooth: bool = option(True, "smooth the landmarks over time (One Euro filter)")
    max_faces: int = option(1, "track up to N faces per frame, a fit each with its face_id "
                            "(1: the largest face)", metavar="N", check=in_range(1, MAX_FACES))

    def config(self) -> FitterConfig:
        """The library's configuration of the fitting these options ask for."""
        return FitterConfig(self.algorithm, self.failure_test, self.appearance, self.occlusion,
                            self.refine, self.refine_with)
