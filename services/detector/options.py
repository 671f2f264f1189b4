"""The detector's options (see :mod:`services.bus.options`)."""

from __future__ import annotations

from dataclasses import dataclass

from services.bus.options import Options, in_range, option


def _max_side_problem(value: int) -> str:
    return "" if value == 0 or 32 <= value <= 4096 else "must be 0 (never) or 32 to 4096"


@dataclass(frozen=True)
class DetectorOptions(Options):
    """How the detector searches."""

    rate: float = option(2.0, "searches a second while no face is tracked (0: only on request)",
                         check=in_range(0, 100))
    idle: float = option(1.0, "seconds without a good fit after which to search",
                         check=in_range(0))
    scale_factor: float = option(1.2, "Haar scale step", check=in_range(1.01, 2.0))
    min_neighbors: int = option(3, "Haar neighbours a detection needs", check=in_range(0, 50))
    min_size: int = option(60, "smallest face side, pixels", check=in_range(8, 4096))
    max_side: int = option(320, "downscale frames to this longer side before detecting "
                           "(0: never)", check=_max_side_problem)
