"""The detector's options (see :mod:`services.bus.options`)."""

from __future__ import annotations

from dataclasses import dataclass

from aamcore.defaults import DETECTOR
from services.bus.options import Options, in_range, option


def _max_side_problem(value: int) -> str:
    return "" if value == 0 or 32 <= value <= 4096 else "must be 0 (never) or 32 to 4096"


@dataclass(frozen=True)
class DetectorOptions(Options):
    """How the detector searches a frame it is asked about."""

    scale_factor: float = option(DETECTOR["scale_factor"], "Haar scale step",
                                 check=in_range(1.01, 2.0))
    min_neighbors: int = option(DETECTOR["min_neighbors"], "Haar neighbours a detection needs",
                                check=in_range(0, 50))
    min_size: int = option(DETECTOR["min_size"][0], "smallest face side, pixels",
                           check=in_range(8, 4096))
    max_side: int = option(DETECTOR["max_side"] or 0, "downscale frames to this longer side "
                           "before detecting (0: never)", check=_max_side_problem)
