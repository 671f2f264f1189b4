"""One file per model: every array in an ``.npz`` plus a JSON header.

Loading never executes code (``allow_pickle=False``). A file written by
another format version is refused with a message naming both versions.

The file holds the :class:`~aamcore.model.aam.AAM` and, optionally, one
*extra* part that this module stores without reading: a JSON header and
named arrays (the fitting model of :mod:`aamcore.fitting.model` is such a
part).
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aamcore.io.landmarks import LandmarkScheme
from aamcore.io.versioned import checked_header, save_npz
from aamcore.model.aam import AAM
from aamcore.model.combined import CombinedModel
from aamcore.model.pca import PCA
from aamcore.model.shape import ShapeModel
from aamcore.model.texture import TextureModel
from aamcore.warp.reference_frame import ReferenceFrame

FORMAT = "aamtrack-model"
FORMAT_VERSION = 3
"""Version 2: the fitting part is a typed section (``extra``), not loose attachments.
Version 3: the fitting part may hold the local-binary cascade (the default method)."""
EXTRA_PREFIX = "extra__"


class ModelFileError(ValueError):
    """A model file is missing, corrupt or of another format version."""


def _pca_arrays(prefix: str, pca: PCA) -> dict[str, np.ndarray]:
    return {
        f"{prefix}_mean": pca.mean,
        f"{prefix}_components": pca.components,
        f"{prefix}_variances": pca.variances,
        f"{prefix}_total": np.array(pca.total_variance),
    }


def _pca_from(prefix: str, arrays: dict[str, np.ndarray]) -> PCA:
    return PCA(
        arrays[f"{prefix}_mean"],
        arrays[f"{prefix}_components"],
        arrays[f"{prefix}_variances"],
        float(arrays[f"{prefix}_total"]),
    )


@dataclass(frozen=True)
class StoredModel:
    """What a model file holds.

    Attributes
    ----------
    aam : AAM
    extra : dict
        The extra part's JSON header (empty when there is none).
    arrays : dict of str to array
        The extra part's arrays.
    """

    aam: AAM
    extra: dict[str, Any]
    arrays: dict[str, np.ndarray]


def header_of(aam: AAM, extra: dict[str, Any] | None = None) -> dict[str, Any]:
    """The JSON header written for ``aam``."""
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "scheme": aam.scheme.to_json(),
        "channels": aam.channels,
        "equalise": aam.equalise,
        "reference": {"size": list(aam.frame.size), "pixels": aam.frame.n_pixels},
        "modes": {
            "shape": aam.shape.n_modes,
            "texture": aam.texture.n_modes,
            "combined": aam.combined.n_modes,
        },
        "variance_kept": {
            "shape": aam.shape.pca.variance_kept,
            "texture": aam.texture.pca.variance_kept,
            "combined": aam.combined.pca.variance_kept,
        },
        "shape_weight": aam.combined.weight,
        "summary": aam.summary,
        "extra": extra or {},
    }


def save_model(
    aam: AAM,
    path: str | Path,
    extra: dict[str, Any] | None = None,
    extra_arrays: dict[str, np.ndarray] | None = None,
) -> Path:
    """Write ``aam`` (and an extra part) to ``path`` (``.npz`` is appended if missing)."""
    path = Path(path)
    if path.suffix != ".npz":
        path = path.with_suffix(path.suffix + ".npz")
    path.parent.mkdir(parents=True, exist_ok=True)
    header = json.dumps(header_of(aam, extra), sort_keys=True).encode()
    arrays = {
        "header": np.frombuffer(header, dtype=np.uint8),
        **_pca_arrays("shape", aam.shape.pca),
        **_pca_arrays("texture", aam.texture.pca),
        **_pca_arrays("combined", aam.combined.pca),
        "frame_triangles": aam.frame.triangles,
    }
    arrays.update({EXTRA_PREFIX + k: v for k, v in (extra_arrays or {}).items()})
    tmp = path.with_suffix(".tmp.npz")
    save_npz(tmp, arrays)
    tmp.replace(path)
    return path


def read_header(path: str | Path) -> dict[str, Any]:
    """Read and check a model file's header without loading the arrays."""
    path = Path(path)
    with _open(path) as data:
        return _checked_header(path, data)


def _open(path: Path) -> Any:
    if not path.is_file():
        raise ModelFileError(f"{path}: model file not found")
    try:
        return np.load(path, allow_pickle=False)
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        why = ("it would need pickled objects, which aamtrack never loads" if "pickle" in str(exc)
               else str(exc))
        raise ModelFileError(f"{path}: not a model file ({why})") from exc


def _checked_header(path: Path, data: Any) -> dict[str, Any]:
    try:
        raw = data["header"] if "header" in data.files else None
    except ValueError as exc:  # an object array: refused without unpickling
        raise ModelFileError(f"{path}: corrupt header ({exc})") from exc
    return checked_header(path, raw, FORMAT, FORMAT_VERSION, "model",
                          "retrain the model with `aamtrack train`", ModelFileError)


def load_model(path: str | Path) -> AAM:
    """Load the AAM of a model file written by :func:`save_model`.

    Raises
    ------
    ModelFileError
        If the file is missing, corrupt, or of another format version.
    """
    return read_model(path).aam


def read_model(path: str | Path) -> StoredModel:
    """Load everything a model file holds: the AAM and its extra part.

    Raises
    ------
    ModelFileError
        If the file is missing, corrupt, or of another format version.
    """
    path = Path(path)
    with _open(path) as data:
        header = _checked_header(path, data)
        try:
            arrays = {name: data[name] for name in data.files}
        except (OSError, ValueError, zipfile.BadZipFile) as exc:
            raise ModelFileError(f"{path}: corrupt array data ({exc})") from exc
    try:
        scheme = LandmarkScheme.from_json(header["scheme"])
        shape = ShapeModel(_pca_from("shape", arrays))
        texture = TextureModel(_pca_from("texture", arrays), int(header["channels"]))
        combined = CombinedModel(
            _pca_from("combined", arrays), float(header["shape_weight"]), shape.n_modes
        )
        frame = ReferenceFrame.from_mean_shape(shape.mean_shape, arrays["frame_triangles"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ModelFileError(f"{path}: incomplete model file ({exc})") from exc
    extra_arrays = {
        k[len(EXTRA_PREFIX) :]: v for k, v in arrays.items() if k.startswith(EXTRA_PREFIX)
    }
    aam = AAM(
        scheme,
        shape,
        texture,
        combined,
        frame,
        equalise=bool(header["equalise"]),
        summary=header.get("summary", {}),
    )
    return StoredModel(aam, header.get("extra", {}), extra_arrays)
