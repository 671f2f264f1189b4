"""What the fitting methods learned, as data: the parts of a fitting model file.

:class:`~aamcore.fitting.model.FittingModel` holds these and writes them to
its file; the algorithm modules read them. Keeping them here, apart from the
algorithms, lets the model be read without importing any algorithm (and the
algorithms import the model module for its type only). The update matrices
of the AAM methods are :class:`~aamcore.fitting.update_matrix.UpdateMatrix`;
the occlusion test's part is :class:`~aamcore.fitting.occlusion.OcclusionModel`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aamcore.fitting.algorithm.ferns import FernStage
from aamcore.fitting.algorithm.local_hog import HogStage
from aamcore.fitting.shape_space import ShapeSpace


@dataclass(frozen=True)
class DescentCascade:
    """What the supervised-descent method learned.

    Attributes
    ----------
    weights : list of (D + 1, Q) float32 arrays
        One regression per stage, the last row the bias.
    hog_cell : int
        HOG cell size used for the features.
    """

    weights: list[np.ndarray]
    hog_cell: int


@dataclass(frozen=True)
class BinaryCascade:
    """What the local-binary method learned.

    Attributes
    ----------
    space : ShapeSpace
    coarse : list of HogStage
        Run from a detection start, before ``tracking``.
    tracking : list of FernStage
        Run from a detection after ``coarse``, and from the previous frame's landmarks.
    quality : FernStage
        Its output (1,) is the predicted ``log(NME)`` of the landmarks it is given.
    threshold : float
        A fit whose quality score is above it has failed.
    report : dict
        How it was trained (JSON-ready).
    restart : list of FernStage
        Run, before ``tracking``, from the mean shape placed by a similarity on the previous
        frame's landmarks: a fit of each frame that keeps no error of the last (empty: none).
    """

    space: ShapeSpace
    coarse: list[HogStage]
    tracking: list[FernStage]
    quality: FernStage
    threshold: float
    report: dict[str, Any] = field(default_factory=dict)
    restart: list[FernStage] = field(default_factory=list)

    def __post_init__(self) -> None:
        if not self.tracking:
            raise ValueError("a local-binary cascade needs at least one fern stage")
        q = self.space.basis.shape[1]
        for k, stage in enumerate([*self.restart, *self.tracking]):
            if stage.bias.shape != (q,) or stage.n_points != self.space.n_points:
                raise ValueError(f"fern stage {k} does not fit the shape space ({q} directions, "
                                 f"{self.space.n_points} points)")
        if self.quality.bias.shape != (1,) or not math.isfinite(self.threshold):
            raise ValueError("the quality stage must give one score and the threshold be finite")

    def arrays(self, prefix: str) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """The JSON header and the named arrays of the cascade, for a model file."""
        arrays = self.space.arrays(f"{prefix}_space")
        for k, stage in enumerate(self.coarse):
            arrays.update(stage.arrays(f"{prefix}_coarse{k}"))
        for k, stage in enumerate(self.tracking):
            arrays.update(stage.arrays(f"{prefix}_fern{k}"))
        for k, stage in enumerate(self.restart):
            arrays.update(stage.arrays(f"{prefix}_restart{k}"))
        arrays.update(self.quality.arrays(f"{prefix}_quality"))
        header = {"coarse": len(self.coarse), "tracking": len(self.tracking),
                  "restart": len(self.restart), "threshold": self.threshold,
                  "report": self.report}
        return header, arrays

    @classmethod
    def from_arrays(cls, header: dict[str, Any], arrays: dict[str, np.ndarray], prefix: str
                    ) -> BinaryCascade:
        """The cascade written by :meth:`arrays`."""
        return cls(
            ShapeSpace.from_arrays(arrays, f"{prefix}_space"),
            [HogStage.from_arrays(arrays, f"{prefix}_coarse{k}")
             for k in range(int(header["coarse"]))],
            [FernStage.from_arrays(arrays, f"{prefix}_fern{k}")
             for k in range(int(header["tracking"]))],
            FernStage.from_arrays(arrays, f"{prefix}_quality"),
            float(header["threshold"]), dict(header.get("report", {})),
            [FernStage.from_arrays(arrays, f"{prefix}_restart{k}")
             for k in range(int(header.get("restart", 0)))],
        )
