"""The fitter's options (see :mod:`services.bus.options`)."""

from __future__ import annotations

from dataclasses import dataclass

from aamcore import defaults
from aamcore.fitting.algorithm import ALGORITHMS
from aamcore.fitting.failure import FAILURE_TESTS
from services.bus.options import Options, in_range, option

WARPS = ("auto", "gpu", "cpu")


@dataclass(frozen=True)
class FitterOptions(Options):
    """The fitting model, algorithm and warp, and how the detector is asked."""

    model: str | None = option(None, "fitting model file (default: the cached default model, "
                               "trained on first use)", metavar="FILE")
    model_limit: int = option(0, "train the default model on the first N images only "
                              "(small, for tests)", metavar="N", check=in_range(0))
    model_images: int = option(defaults.MODEL_UPDATE_IMAGES, "images for the default model's "
                               "update matrices", metavar="N", check=in_range(1, 10000))
    algorithm: str = option(defaults.ALGORITHM, "fitting algorithm", choices=tuple(ALGORITHMS))
    failure_test: str = option(defaults.FAILURE_TEST, "how a failed fit is recognised (auto: "
                               "the learned quality score for local-binary, chi2 for the AAM "
                               "methods)", choices=FAILURE_TESTS)
    appearance: bool = option(True, "sample the AAM appearance of every good fit of a method "
                              "that computes none (local-binary; one texture warp per fit), "
                              "for the expression service")
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
