"""The pose service's options: the pose stage's part of the options tree."""

from __future__ import annotations

from dataclasses import dataclass

from aamcore.fitting.config import NewFaces
from aamcore.operators import options as stages
from aamcore.settings import group
from services.bus.options import Options, in_range, option


@dataclass(frozen=True)
class PoseOptions(Options):
    """The pose stage, and the backlog of fits."""

    pose: stages.PoseOptions = group(stages.PoseOptions(), "the pose stage", "pose")
    new_faces: NewFaces = group(NewFaces(), "the fit stage's faces: how long a face's state "
                                "is kept", "new_faces")
    capacity: int = option(64, "latest fits kept while busy: a burst of fast-paced fits is "
                           "worked through, not dropped", check=in_range(1, 1024))
