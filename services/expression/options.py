"""The expression service's options: the expression stage's part of the options tree."""

from __future__ import annotations

from dataclasses import dataclass

from aamcore.fitting.config import NewFaces
from aamcore.operators import options as stages
from aamcore.settings import group
from services.bus.options import Options, in_range, option


@dataclass(frozen=True)
class ExpressionOptions(Options):
    """The expression stage, the model its classifier must be made for, the backlog."""

    expression: stages.ExpressionOptions = group(stages.ExpressionOptions(),
                                                 "the expression stage", "expression")
    fitting_model: str | None = option(None, "the fitting model file the fitter uses, to check "
                                       "that the classifier was trained for it",
                                       metavar="FILE", flag="--model")
    algorithm: str | None = option(None, "the fitter's algorithm, to check that the classifier "
                                   "was trained on its fits (with --model)", metavar="NAME")
    new_faces: NewFaces = group(NewFaces(), "the fit stage's faces: how long a face's state "
                                "is kept", "new_faces")
    capacity: int = option(48, "latest fits kept while busy: a burst of fast frames is worked "
                           "through, not dropped (a dropped fit is a gap in the stream's "
                           "reference and smoothing)", check=in_range(1, 1024))
