"""The detector's options: the detect stage's part of the options tree."""

from __future__ import annotations

from dataclasses import dataclass

from aamcore.operators.options import DetectOptions
from aamcore.settings import group
from services.bus.options import Options


@dataclass(frozen=True)
class DetectorOptions(Options):
    """How the detector searches a frame it is asked about."""

    detect: DetectOptions = group(DetectOptions(), "the detect stage", "detect")
