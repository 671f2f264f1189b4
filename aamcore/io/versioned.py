"""The JSON header of a versioned ``.npz`` file (model files, classifier files)."""

from __future__ import annotations

import json
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

_EPOCH = (1980, 1, 1, 0, 0, 0)
"""The date of every entry: ``np.savez`` stamps the time of writing, so two files of equal
arrays would differ."""


def save_npz(path: str | Path, arrays: Mapping[str, np.ndarray]) -> Path:
    """Write ``arrays`` as an uncompressed ``.npz`` that ``np.load`` reads, byte for byte the
    same for the same arrays (entries in the given order, no time stamps, no pickles)."""
    path = Path(path)
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED, allowZip64=True) as archive:
        for name, value in arrays.items():
            info = zipfile.ZipInfo(f"{name}.npy", date_time=_EPOCH)
            with archive.open(info, "w", force_zip64=True) as out:
                np.lib.format.write_array(out, np.asanyarray(value), allow_pickle=False)
    return path


def checked_header(
    path: Path, raw: np.ndarray | None, format_name: str, version: int, what: str,
    advice: str, error: type[ValueError],
) -> dict[str, Any]:
    """Decode a file's header (uint8 JSON bytes) and check its format and version.

    Parameters
    ----------
    path : Path
        For the messages.
    raw : (B,) uint8 array or None
        The header entry, None when the file has none.
    format_name : str
        The ``format`` the header must name.
    version : int
        The ``format_version`` this program reads.
    what : str
        What the file is, e.g. ``"model"``.
    advice : str
        What to do with a file of another version.
    error : type
        The exception raised.

    Raises
    ------
    error
        Naming the file and what is wrong (for another version, both versions).
    """
    if raw is None:
        raise error(f"{path}: no header: not an aamtrack {what} file")
    try:
        header = json.loads(raw.tobytes().decode("utf-8"))
    except (ValueError, UnicodeDecodeError) as exc:
        raise error(f"{path}: corrupt header ({exc})") from exc
    if not isinstance(header, dict) or header.get("format") != format_name:
        raise error(f"{path}: not an aamtrack {what} file")
    found = header.get("format_version")
    if found != version:
        raise error(f"{path}: {what} file format version {found}, this aamtrack reads version "
                    f"{version}: {advice}")
    return header
