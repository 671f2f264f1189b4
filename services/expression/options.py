"""The expression service's options (see :mod:`services.bus.options`)."""

from __future__ import annotations

from dataclasses import dataclass

from aamcore.tracker_config import TrackerConfig
from services.bus.options import Options, in_range, option, setting_option


@dataclass(frozen=True)
class ExpressionOptions(Options):
    """The classifier, how its scores are smoothed, the backlog of fits."""

    classifier: str | None = option(None, "expression classifier file (.npz)", metavar="FILE")
    model: str | None = option(None, "the fitting model file the fitter uses, to check that the "
                               "classifier was trained for it", metavar="FILE")
    algorithm: str | None = option(None, "the fitter's algorithm, to check that the classifier "
                                   "was trained on its fits (with --model)", metavar="NAME")
    smooth: int = option(1, "average the probabilities over the last N classified frames (1: none)",
                         metavar="N", check=in_range(1, 1000))
    hold: int = setting_option(TrackerConfig.setting("expression_hold"))
    capacity: int = option(48, "latest fits kept while busy: a burst of fast frames is worked "
                           "through, not dropped (a dropped fit is a gap in the stream's "
                           "reference and smoothing)", check=in_range(1, 1024))
