"""The expression service's options (see :mod:`services.bus.options`)."""

from __future__ import annotations

from dataclasses import dataclass

from services.bus.options import Options, in_range, option


@dataclass(frozen=True)
class ExpressionOptions(Options):
    """The classifier and how its scores are smoothed."""

    classifier: str | None = option(None, "expression classifier file (.npz)", metavar="FILE")
    model: str | None = option(None, "the fitting model file the fitter uses, to check that the "
                               "classifier was trained for it", metavar="FILE")
    smooth: int = option(1, "average the scores over the last N good fits (1: none)",
                         metavar="N", check=in_range(1, 1000))
    capacity: int = option(8, "latest fits kept while busy", check=in_range(1, 1024))
