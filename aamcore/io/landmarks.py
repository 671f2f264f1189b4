"""Landmark schemes: how many points, how they connect, and what they name.

A :class:`LandmarkScheme` is plain data so that it can be stored in a model
file's JSON header and rebuilt from it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass(frozen=True)
class LandmarkScheme:
    """A landmark markup.

    Parameters
    ----------
    name : str
        Short identifier, e.g. ``"ibug68"`` or ``"imm73"``.
    n_points : int
        Number of landmarks.
    edges : tuple of (int, int)
        Pairs of point indices drawn as lines (the contour connectivity).
    groups : dict of str to tuple of int
        Named point groups: ``jaw``, ``brows``, ``eyes``, ``nose``, ``mouth``
        and, where the markup has them, finer ones.
    eye_corners : (int, int)
        Indices of the outer eye corners, image-left first, used to
        normalise errors (NME).
    """

    name: str
    n_points: int
    edges: tuple[tuple[int, int], ...]
    groups: dict[str, tuple[int, ...]] = field(default_factory=dict)
    eye_corners: tuple[int, int] = (0, 1)

    def __post_init__(self) -> None:
        for a, b in self.edges:
            if not (0 <= a < self.n_points and 0 <= b < self.n_points):
                raise ValueError(f"scheme {self.name}: edge ({a}, {b}) out of range")
        for group, idx in self.groups.items():
            if any(not 0 <= i < self.n_points for i in idx):
                raise ValueError(f"scheme {self.name}: group {group} has an index out of range")

    def inter_ocular(self, points: np.ndarray) -> float:
        """Distance between the outer eye corners of ``points`` of shape (N, 2)."""
        a, b = self.eye_corners
        return float(np.linalg.norm(points[a] - points[b]))

    def to_json(self) -> dict[str, Any]:
        """Return a JSON-serialisable description."""
        return {
            "name": self.name,
            "n_points": self.n_points,
            "edges": [list(e) for e in self.edges],
            "groups": {k: list(v) for k, v in self.groups.items()},
            "eye_corners": list(self.eye_corners),
        }

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> LandmarkScheme:
        """Rebuild a scheme written by :meth:`to_json`."""
        return cls(
            name=str(data["name"]),
            n_points=int(data["n_points"]),
            edges=tuple((int(a), int(b)) for a, b in data["edges"]),
            groups={str(k): tuple(int(i) for i in v) for k, v in data["groups"].items()},
            eye_corners=(int(data["eye_corners"][0]), int(data["eye_corners"][1])),
        )


def _chain(start: int, stop: int, closed: bool = False) -> list[tuple[int, int]]:
    pairs = [(i, i + 1) for i in range(start, stop - 1)]
    if closed:
        pairs.append((stop - 1, start))
    return pairs


def _ibug68() -> LandmarkScheme:
    edges = (
        _chain(0, 17)
        + _chain(17, 22)
        + _chain(22, 27)
        + _chain(27, 31)
        + _chain(31, 36)
        + [(30, 33)]
        + _chain(36, 42, closed=True)
        + _chain(42, 48, closed=True)
        + _chain(48, 60, closed=True)
        + _chain(60, 68, closed=True)
    )
    groups = {
        "jaw": tuple(range(0, 17)),
        "brows": tuple(range(17, 27)),
        "nose": tuple(range(27, 36)),
        "eyes": tuple(range(36, 48)),
        "mouth": tuple(range(48, 68)),
        "right_eye": tuple(range(36, 42)),
        "left_eye": tuple(range(42, 48)),
        "inner_mouth": tuple(range(60, 68)),
    }
    return LandmarkScheme("ibug68", 68, tuple(edges), groups, eye_corners=(36, 45))


IBUG68 = _ibug68()
"""The iBUG / 300-W 68-point markup used by LFPW."""


def _ibug68_mirror() -> np.ndarray:
    pairs = [(k, 16 - k) for k in range(17)]  # jaw
    pairs += [(17 + k, 26 - k) for k in range(5)]  # brows
    pairs += [(27, 27), (28, 28), (29, 29), (30, 30)]  # nose bridge
    pairs += [(31 + k, 35 - k) for k in range(5)]  # nostrils
    pairs += [(36, 45), (37, 44), (38, 43), (39, 42), (40, 47), (41, 46)]  # eyes
    pairs += [(48 + k, 54 - k) for k in range(7)]  # upper outer lip
    pairs += [(55, 59), (56, 58), (57, 57)]  # lower outer lip
    pairs += [(60 + k, 64 - k) for k in range(5)]  # upper inner lip
    pairs += [(65, 67), (66, 66)]  # lower inner lip
    perm = np.full(68, -1, dtype=np.int64)
    for a, b in pairs:
        perm[a], perm[b] = b, a
    return perm


IBUG68_MIRROR = _ibug68_mirror()
"""Index of each iBUG-68 point's mirror partner, (68,) int: the subject's right
eye's outer corner (36) becomes the left eye's (45) in a left-right flipped image."""


def mirror_points(points: np.ndarray, width: int, permutation: np.ndarray) -> np.ndarray:
    """Landmarks (N, 2) of the left-right flipped image of ``width`` pixels.

    ``x`` becomes ``width - 1 - x`` (0-based pixel centres, as
    :func:`cv2.flip` maps them) and the points are renumbered by
    ``permutation`` (N,) (e.g. :data:`IBUG68_MIRROR`) so that each keeps its meaning.

    Raises
    ------
    ValueError
        When ``points`` do not have one row per entry of ``permutation``.
    """
    pts = np.asarray(points, dtype=np.float64)
    if pts.shape != (len(permutation), 2):
        raise ValueError(f"points {pts.shape} do not match a {len(permutation)}-point permutation")
    flipped = pts[permutation].copy()
    flipped[:, 0] = width - 1 - flipped[:, 0]
    return flipped

# IMM Frontal: the 12 contour paths of the AAM-API files, by path number.
IMM_PATH_GROUPS = {
    0: "brows",
    1: "brows",
    2: "eyes",
    3: "eyes",
    4: "eyes",  # pupils
    5: "eyes",
    6: "nose",
    7: "nose",
    8: "mouth",
    9: "mouth",
    10: "mouth",
    11: "jaw",
}


def imm_scheme(paths: np.ndarray, connects_to: np.ndarray) -> LandmarkScheme:
    """Build the IMM 73-point scheme from an ``.asf`` file's topology.

    Parameters
    ----------
    paths : (73,) int array
        Contour path of each point.
    connects_to : (73,) int array
        The point each point connects to (itself for an isolated point).
    """
    n = len(paths)
    edges = tuple((i, int(j)) for i, j in enumerate(connects_to) if int(j) != i)
    groups: dict[str, list[int]] = {}
    for i, p in enumerate(paths):
        groups.setdefault(IMM_PATH_GROUPS.get(int(p), f"path{int(p)}"), []).append(i)
    # Outer eye corners: first point of the image-left eye (path 2) and of the
    # image-right eye (path 3) in the IMM markup.
    left = int(np.flatnonzero(paths == 2)[0]) if np.any(paths == 2) else 0
    right = int(np.flatnonzero(paths == 3)[0]) if np.any(paths == 3) else 1
    return LandmarkScheme(
        f"imm{n}", n, edges, {k: tuple(v) for k, v in groups.items()}, eye_corners=(left, right)
    )


def generic_scheme(n_points: int) -> LandmarkScheme:
    """A scheme with no connectivity for markups this module does not know."""
    return LandmarkScheme(f"points{n_points}", n_points, (), {}, eye_corners=(0, 1))


def scheme_for(n_points: int) -> LandmarkScheme:
    """Return the known scheme for a point count (68: iBUG), else a generic one."""
    return IBUG68 if n_points == 68 else generic_scheme(n_points)


def as_points(points: np.ndarray, name: str = "points") -> np.ndarray:
    """``points`` as a float64 (N, 2) array of finite values, N >= 1.

    Raises
    ------
    ValueError
        Naming ``name``, for another shape or NaN or infinite values.
    """
    arr = np.asarray(points, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 2 or len(arr) == 0:
        raise ValueError(f"{name} must have shape (N, 2), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} holds NaN or infinite values")
    return arr

