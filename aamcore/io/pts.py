"""300-W ``.pts`` landmark files (iBUG markup, 1-based pixel coordinates)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from aamcore.io.sample import DatasetError


def read_pts(path: str | Path) -> np.ndarray:
    """Read a ``.pts`` file as 0-based pixel coordinates, shape (N, 2).

    Raises
    ------
    DatasetError
        Naming the file, if it is missing, truncated, or its point count
        disagrees with its header.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="latin-1")
    except OSError as exc:
        raise DatasetError(f"{path}: cannot read ({exc.strerror})") from exc
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    n_declared = None
    for ln in lines:
        if ln.lower().startswith("n_points"):
            try:
                n_declared = int(ln.split(":", 1)[1])
            except (IndexError, ValueError) as exc:
                raise DatasetError(f"{path}: bad header line {ln!r}") from exc
    if "{" not in lines:
        raise DatasetError(f"{path}: no '{{' opening the point list")
    if "}" not in lines:
        raise DatasetError(f"{path}: truncated, no closing '}}'")
    body = lines[lines.index("{") + 1 : lines.index("}")]
    try:
        points = np.array([[float(v) for v in ln.split()[:2]] for ln in body], dtype=np.float64)
    except ValueError as exc:
        raise DatasetError(f"{path}: a point line is not numeric") from exc
    if points.ndim != 2 or points.shape[1] != 2 or len(points) == 0:
        raise DatasetError(f"{path}: no valid points")
    if n_declared is not None and n_declared != len(points):
        raise DatasetError(f"{path}: header says {n_declared} points, file has {len(points)}")
    if not np.all(np.isfinite(points)):
        raise DatasetError(f"{path}: non-finite coordinates")
    return points - 1.0
