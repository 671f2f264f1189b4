"""The fitting model: an AAM with everything its fitting algorithms learned, typed.

A :class:`FittingModel` holds the box-to-shape mapping of the initialisation,
one update matrix per pyramid level (fixed-Jacobian and multi-resolution
fitting), the supervised-descent cascade, the local-binary cascade (the
default method, with its quality stage and failure threshold) and the
occlusion test's statistics. It is saved as the *extra* part of the AAM's
model file (:mod:`aamcore.model.file`), so one file holds a model ready to
track with. Each part is a data class of :mod:`aamcore.fitting.learned` (or
:mod:`~aamcore.fitting.update_matrix`, :mod:`~aamcore.fitting.occlusion`):
reading a model imports no fitting algorithm.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aamcore.detection.mapping import BoxToShapeMapping
from aamcore.fitting.learned import BinaryCascade, DescentCascade
from aamcore.fitting.occlusion import OcclusionModel
from aamcore.fitting.update_matrix import PerturbationScheme, UpdateMatrix
from aamcore.model.aam import AAM
from aamcore.model.file import ModelFileError, read_model, save_model

KIND = "fitting"
"""The ``kind`` of the model file's extra part written here."""


@dataclass
class FittingModel:
    """An AAM and what fitting it learned.

    Attributes
    ----------
    aam : AAM
    mapping : BoxToShapeMapping
        From a face box to a start shape.
    updates : list of UpdateMatrix
        ``updates[l]`` for images halved ``l`` times (level 0: full resolution).
    cascade : DescentCascade or None
        The supervised-descent cascade, when one was trained.
    binary : BinaryCascade or None
        The local-binary cascade, when one was trained (68-point models).
    occlusion : OcclusionModel or None
        What the occlusion test learned, when it was trained.
    """

    aam: AAM
    mapping: BoxToShapeMapping
    updates: list[UpdateMatrix]
    cascade: DescentCascade | None = None
    binary: BinaryCascade | None = None
    occlusion: OcclusionModel | None = None

    def __post_init__(self) -> None:
        expected = (self.aam.n_appearance + 4, self.aam.texture_basis.shape[0])
        for level, update in enumerate(self.updates):
            if update.R.shape != expected:
                raise ValueError(f"update matrix of level {level} has shape {update.R.shape}, "
                                 f"the AAM needs {expected}")
        points = self.aam.scheme.n_points
        if self.occlusion is not None and self.occlusion.n_points != points:
            raise ValueError(f"occlusion statistics of {self.occlusion.n_points} landmarks, "
                             f"the AAM has {points}")

    @property
    def update_method(self) -> str:
        """How the update matrices were learned (``jacobian``, ``regression``), or ``""``."""
        return self.updates[0].method if self.updates else ""

    def update(self, level: int = 0) -> UpdateMatrix:
        """The update matrix of pyramid ``level``."""
        if not 0 <= level < len(self.updates):
            raise ValueError(f"this model has no update matrix for pyramid level {level}: "
                             "train it with `aamtrack train --fit`")
        return self.updates[level]

    def save(self, path: str | Path) -> Path:
        """Write the AAM and its fitting part to one model file."""
        header, arrays = _record(self)
        return save_model(self.aam, path, header, arrays)

    @classmethod
    def load(cls, path: str | Path) -> FittingModel:
        """Read a model file written by :meth:`save`.

        Raises
        ------
        ModelFileError
            When the file is not a model file of this version, or holds an
            AAM without its fitting part (trained without ``--fit``).
        """
        stored = read_model(path)
        if stored.extra.get("kind") != KIND:
            raise ModelFileError(f"{path}: this model has no fitting part: train it with "
                                 "`aamtrack train --fit`")
        try:
            return _from_record(stored.aam, stored.extra, stored.arrays)
        except (KeyError, TypeError, ValueError) as exc:
            raise ModelFileError(f"{path}: incomplete fitting part ({exc})") from exc


def load_fitting_model(path: str | Path) -> FittingModel:
    """:meth:`FittingModel.load`."""
    return FittingModel.load(path)


def _record(model: FittingModel) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The JSON header and arrays of the fitting part."""
    arrays = {f"update_{level}": u.R for level, u in enumerate(model.updates)}
    header: dict[str, Any] = {
        "kind": KIND,
        "mapping": model.mapping.to_json(include_reference=False),
        "updates": [{"method": u.method, "images": u.images, "experiments": u.experiments,
                     "scheme": asdict(u.scheme)} for u in model.updates],
        "cascade": None,
    }
    if model.cascade is not None:
        arrays.update({f"descent_{k}": w for k, w in enumerate(model.cascade.weights)})
        header["cascade"] = {"stages": len(model.cascade.weights),
                             "hog_cell": model.cascade.hog_cell}
    header["binary"] = None
    if model.binary is not None:
        header["binary"], binary_arrays = model.binary.arrays("binary")
        arrays.update(binary_arrays)
    header["occlusion"] = None
    if model.occlusion is not None:
        header["occlusion"], occlusion_arrays = model.occlusion.arrays("occlusion")
        arrays.update(occlusion_arrays)
    return header, arrays


def _from_record(
    aam: AAM, header: dict[str, Any], arrays: dict[str, np.ndarray]
) -> FittingModel:
    mapping = BoxToShapeMapping.from_json(header["mapping"], reference=aam.shape.mean_shape)
    updates = []
    for level, info in enumerate(header["updates"]):
        scheme = PerturbationScheme(**{k: tuple(v) for k, v in info["scheme"].items()})
        updates.append(UpdateMatrix(arrays[f"update_{level}"].astype(np.float32), info["method"],
                                    int(info["images"]), int(info["experiments"]), scheme))
    cascade = None
    if header.get("cascade"):
        info = header["cascade"]
        weights = [arrays[f"descent_{k}"] for k in range(int(info["stages"]))]
        cascade = DescentCascade(weights, int(info["hog_cell"]))
    binary = None
    if header.get("binary"):
        binary = BinaryCascade.from_arrays(header["binary"], arrays, "binary")
        if binary.space.n_points != aam.scheme.n_points:
            raise ValueError(f"local-binary cascade of {binary.space.n_points} points, "
                             f"the AAM has {aam.scheme.n_points}")
    occlusion = None
    if header.get("occlusion"):
        occlusion = OcclusionModel.from_arrays(header["occlusion"], arrays, "occlusion")
    return FittingModel(aam, mapping, updates, cascade, binary, occlusion)
