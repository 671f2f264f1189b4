"""The fitter's options (see :mod:`services.bus.options`): the fitting model, how the detector
is asked, and the tracker's configuration (:class:`aamcore.tracker_config.TrackerConfig`),
each of whose values is an option of its own (``--algorithm``, ``--refit-every``, ...)."""

from __future__ import annotations

from dataclasses import dataclass

from aamcore import defaults
from aamcore.tracker_config import TRACKER, TrackerConfig
from services.bus.options import Options, in_range, option, settings_option

UPDATE_METHODS = ("jacobian", "regression")
"""As :data:`aamcore.fitting.training.update.METHODS` (not imported: options load light)."""
ELSEWHERE = ("expression_hold",)
"""The tracker's values the fitter leaves to another service (the expression service's
``--hold``)."""


@dataclass(frozen=True)
class FitterOptions(Options):
    """The fitting model, the tracker's configuration, and how the detector is asked."""

    model: str | None = option(None, "fitting model file (default: the cached default model, "
                               "trained on first use)", metavar="FILE")
    model_limit: int = option(0, "train the default model on the first N images only "
                              "(small, for tests)", metavar="N", check=in_range(0))
    model_images: int = option(defaults.MODEL_UPDATE_IMAGES, "images for the default model's "
                               "update matrices", metavar="N", check=in_range(1, 10000))
    model_update: str = option("jacobian", "how the default model's update matrices are learned "
                               "(the fixed-Jacobian AAM's): jacobian (Algorithm 6) or regression "
                               "(Algorithm 5)", choices=UPDATE_METHODS)
    tracking: TrackerConfig = settings_option(TRACKER, without=ELSEWHERE)
    detect_timeout: float = option(1.0, "seconds to wait for the detector service",
                                   check=in_range(0.01, 60))
    local_for: float = option(5.0, "seconds to detect locally after the service did not answer",
                              check=in_range(0))
    capacity: int = option(2, "latest frames kept while busy (older ones are dropped)",
                           check=in_range(1, 1024))

    @property
    def algorithm(self) -> str:
        """The fitting algorithm (what the classifier and the preflight check ask of it)."""
        return self.tracking.fitting.algorithm

    def config(self) -> TrackerConfig:
        """The library's configuration of the tracking these options ask for."""
        return self.tracking
