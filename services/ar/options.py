"""The glasses AR service's options: the overlay stage's part of the options tree."""

from __future__ import annotations

from dataclasses import dataclass

from aamcore.operators.options import OverlayOptions
from aamcore.settings import group
from services.bus.options import Options, in_range, option
from services.bus.shm import POOL_IMAGES


@dataclass(frozen=True)
class AROptions(Options):
    """The overlay stage, and how overlays are sent."""

    overlay: OverlayOptions = group(OverlayOptions(), "the overlay stage", "overlay")
    jpeg: int = option(0, "publish overlays as JPEG of quality Q (0: raw)", metavar="Q",
                       check=in_range(0, 100))
    capacity: int = option(16, "latest poses kept while busy", check=in_range(1, 1024))
    backend: str = option("egl", "moderngl standalone backend")
    shm_overlays: int = option(POOL_IMAGES, "overlays the shared-memory pool holds, each written "
                             "into it once (0: none, every one over the network)", metavar="N",
                             check=in_range(0, 256))
