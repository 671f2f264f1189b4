"""The pose service's options (see :mod:`services.bus.options`)."""

from __future__ import annotations

from dataclasses import dataclass

from aamcore import defaults
from aamcore.tracker_config import TrackerConfig
from services.bus.options import OptionError, Options, in_range, option, setting_option


@dataclass(frozen=True)
class PoseOptions(Options):
    """The camera the poses are estimated for, and how."""

    fov: float = option(defaults.FOV_DEG, "assumed horizontal field of view, degrees",
                        check=in_range(1, 179))
    calibration: str | None = option(None, "camera calibration file (.yaml, .xml, .json)",
                                     metavar="FILE")
    capacity: int = option(64, "latest fits kept while busy: a burst of fast-paced fits is "
                           "worked through, not dropped", check=in_range(1, 1024))
    smooth: bool = setting_option(TrackerConfig.setting("smoothing"))
    estimator: str = option(defaults.POSE_ESTIMATOR,
                            "head-pose estimator: contour (jaw landmarks matched to the outline "
                            "seen), posit (the thesis's, without the jaw), contour+calib "
                            "(contour with a head model learned from the person)",
                            choices=defaults.POSE_ESTIMATORS)

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.calibration is not None and self.fov != defaults.FOV_DEG:
            raise OptionError("give --fov or --calibration, not both")
