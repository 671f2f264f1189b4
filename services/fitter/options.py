"""The fitter's options: the model and the fit stage's parts of the options tree
(:mod:`aamcore.operators.options`), and how the detector is asked."""

from __future__ import annotations

from dataclasses import dataclass

from aamcore.operators.options import FitOptions, ModelOptions
from aamcore.settings import group
from services.bus.options import Options, in_range, option


@dataclass(frozen=True)
class FitterOptions(Options):
    """The fitting model, the fit stage, and how the detector is asked."""

    model: ModelOptions = group(ModelOptions(), "the fitting model", "model")
    fit: FitOptions = group(FitOptions(), "the fit stage")
    detect_timeout: float = option(1.0, "seconds to wait for the detector service",
                                   check=in_range(0.01, 60))
    local_for: float = option(5.0, "seconds to detect locally after the service did not answer",
                              check=in_range(0))
    capacity: int = option(2, "latest frames kept while busy (older ones are dropped)",
                           check=in_range(1, 1024))

    @property
    def algorithm(self) -> str:
        """The fitting algorithm (what the classifier and the preflight check ask of it)."""
        return self.fit.fitting.algorithm
