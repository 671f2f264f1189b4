"""AAM-API ``.asf`` shape files (IMM Frontal Face Database).

Each point line is ``path type x_rel y_rel point_no connects_from connects_to
...`` with coordinates as fractions of the image size; the line after the
points names the host image.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aamcore.io.sample import DatasetError


@dataclass(frozen=True)
class AsfShape:
    """The content of one ``.asf`` file.

    Attributes
    ----------
    rel_points : (N, 2) float64 array
        Point coordinates as fractions of image width and height.
    paths : (N,) int array
        Contour path of each point.
    connects_from, connects_to : (N,) int arrays
        Contour topology.
    image_name : str
        Host image file name, relative to the ``.asf`` file's folder.
    """

    rel_points: np.ndarray
    paths: np.ndarray
    connects_from: np.ndarray
    connects_to: np.ndarray
    image_name: str

    def pixels(self, width: int, height: int) -> np.ndarray:
        """Points in pixels, shape (N, 2), for an image of the given size."""
        return self.rel_points * np.array([width, height], dtype=np.float64)


def read_asf(path: str | Path) -> AsfShape:
    """Parse an ``.asf`` file.

    Raises
    ------
    DatasetError
        Naming the file, if it is missing, truncated or malformed.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="latin-1")
    except OSError as exc:
        raise DatasetError(f"{path}: cannot read ({exc.strerror})") from exc
    lines = [ln.strip() for ln in text.splitlines()]
    lines = [ln for ln in lines if ln and not ln.startswith("#")]
    if not lines:
        raise DatasetError(f"{path}: empty .asf file")
    try:
        n = int(lines[0])
    except ValueError as exc:
        raise DatasetError(f"{path}: first line {lines[0]!r} is not a point count") from exc
    if n <= 0:
        raise DatasetError(f"{path}: point count {n} is not positive")
    if len(lines) < n + 2:
        raise DatasetError(f"{path}: truncated, {n} points declared, {len(lines) - 1} lines follow")
    rows = []
    for k, line in enumerate(lines[1 : n + 1]):
        fields = line.split()
        if len(fields) < 7:
            raise DatasetError(f"{path}: point line {k} has {len(fields)} fields, expected >= 7")
        try:
            rows.append([float(f) for f in fields[:7]])
        except ValueError as exc:
            raise DatasetError(f"{path}: point line {k} is not numeric: {line!r}") from exc
    arr = np.array(rows)
    if not np.all(np.isfinite(arr)):
        raise DatasetError(f"{path}: non-finite coordinates")
    order = np.argsort(arr[:, 4], kind="stable")
    arr = arr[order]
    if not np.array_equal(arr[:, 4].astype(int), np.arange(n)):
        raise DatasetError(f"{path}: point numbers are not 0..{n - 1}")
    return AsfShape(
        rel_points=arr[:, 2:4].copy(),
        paths=arr[:, 0].astype(int),
        connects_from=arr[:, 5].astype(int),
        connects_to=arr[:, 6].astype(int),
        image_name=lines[n + 1],
    )
