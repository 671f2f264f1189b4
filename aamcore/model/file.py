"""One file per model: every array in an ``.npz`` plus a JSON header.

Loading never executes code (``allow_pickle=False``). A file written by
another format version is refused with a message naming both versions.
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from aamcore.io.landmarks import LandmarkScheme
from aamcore.model.aam import AAM
from aamcore.model.combined import CombinedModel
from aamcore.model.pca import PCA
from aamcore.model.shape import ShapeModel
from aamcore.model.texture import TextureModel
from aamcore.warp.reference_frame import ReferenceFrame

FORMAT = "aamtrack-model"
FORMAT_VERSION = 1
ATTACHMENT_PREFIX = "attach__"


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


def header_of(aam: AAM) -> dict[str, Any]:
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
        "attachments": aam.attachment_header,
    }


def save_model(aam: AAM, path: str | Path) -> Path:
    """Write ``aam`` to ``path`` (``.npz`` is appended if missing)."""
    path = Path(path)
    if path.suffix != ".npz":
        path = path.with_suffix(path.suffix + ".npz")
    path.parent.mkdir(parents=True, exist_ok=True)
    header = json.dumps(header_of(aam), sort_keys=True).encode()
    arrays = {
        "header": np.frombuffer(header, dtype=np.uint8),
        **_pca_arrays("shape", aam.shape.pca),
        **_pca_arrays("texture", aam.texture.pca),
        **_pca_arrays("combined", aam.combined.pca),
        "frame_triangles": aam.frame.triangles,
    }
    arrays.update({ATTACHMENT_PREFIX + k: v for k, v in aam.attachments.items()})
    tmp = path.with_suffix(".tmp.npz")
    np.savez(tmp, **arrays)
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
        raise ModelFileError(f"{path}: not a model file ({exc})") from exc


def _checked_header(path: Path, data: Any) -> dict[str, Any]:
    if "header" not in data.files:
        raise ModelFileError(f"{path}: no header: not an aamtrack model file")
    try:
        header = json.loads(data["header"].tobytes().decode())
    except (ValueError, UnicodeDecodeError) as exc:
        raise ModelFileError(f"{path}: corrupt header ({exc})") from exc
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise ModelFileError(f"{path}: not an aamtrack model file")
    version = header.get("format_version")
    if version != FORMAT_VERSION:
        raise ModelFileError(
            f"{path}: model file format version {version}, this aamtrack reads version "
            f"{FORMAT_VERSION}: retrain the model with `aamtrack train`"
        )
    return header


def load_model(path: str | Path) -> AAM:
    """Load a model written by :func:`save_model`.

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
    attachments = {
        k[len(ATTACHMENT_PREFIX) :]: v for k, v in arrays.items() if k.startswith(ATTACHMENT_PREFIX)
    }
    return AAM(
        scheme,
        shape,
        texture,
        combined,
        frame,
        equalise=bool(header["equalise"]),
        summary=header.get("summary", {}),
        attachments=attachments,
        attachment_header=header.get("attachments", {}),
    )
