"""Triangle meshes built in code: tubes swept along paths, flat fans, ellipsoids."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class TriMesh:
    """An indexed triangle mesh with per-vertex normals.

    Attributes
    ----------
    vertices : (V, 3) float32 array
    normals : (V, 3) float32 array
        Unit normals.
    triangles : (F, 3) uint32 array
        Vertex indices.
    """

    vertices: np.ndarray
    normals: np.ndarray
    triangles: np.ndarray

    def __post_init__(self) -> None:
        v = np.asarray(self.vertices, dtype=np.float32)
        n = np.asarray(self.normals, dtype=np.float32)
        t = np.asarray(self.triangles, dtype=np.int64)
        if v.ndim != 2 or v.shape[1] != 3 or n.shape != v.shape:
            raise ValueError(f"vertices {v.shape} and normals {n.shape} must both be (V, 3)")
        if t.ndim != 2 or t.shape[1] != 3:
            raise ValueError(f"triangles must be (F, 3), got {t.shape}")
        if t.size and (t.min() < 0 or t.max() >= len(v)):
            raise ValueError(f"triangle index out of range 0..{len(v) - 1}")
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "normals", n)
        object.__setattr__(self, "triangles", t.astype(np.uint32))

    @property
    def n_triangles(self) -> int:
        return len(self.triangles)


def concatenate(meshes: Sequence[TriMesh]) -> TriMesh:
    """One mesh holding ``meshes`` in order (triangles keep their order)."""
    offsets = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
    return TriMesh(
        np.vstack([m.vertices for m in meshes]),
        np.vstack([m.normals for m in meshes]),
        np.vstack([m.triangles.astype(np.int64) + o for m, o in zip(meshes, offsets, strict=True)]),
    )


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def path_tangents(path: np.ndarray, closed: bool) -> np.ndarray:
    """Unit tangents (K, 3) of a polyline (K, 3) by central differences."""
    if closed:
        return _unit(np.roll(path, -1, axis=0) - np.roll(path, 1, axis=0))
    return _unit(np.gradient(path, axis=0))


def rotation_minimising_normals(path: np.ndarray, tangents: np.ndarray) -> np.ndarray:
    """Normals (K, 3) along a path that twist as little as possible (double reflection).

    Wang, Jüttler, Zheng and Liu (2008), "Computation of rotation minimizing
    frames". The first normal is any unit vector perpendicular to the first
    tangent; for a planar path it is the plane's normal all along.
    """
    t0 = tangents[0]
    helper = np.eye(3)[int(np.argmin(np.abs(t0)))]
    normals = np.empty_like(path)
    normals[0] = _unit(np.cross(t0, helper))
    for i in range(len(path) - 1):
        v1 = path[i + 1] - path[i]
        c1 = float(v1 @ v1)
        if c1 == 0.0:
            normals[i + 1] = normals[i]
            continue
        r_l = normals[i] - (2.0 / c1) * (v1 @ normals[i]) * v1
        t_l = tangents[i] - (2.0 / c1) * (v1 @ tangents[i]) * v1
        v2 = tangents[i + 1] - t_l
        c2 = float(v2 @ v2)
        normals[i + 1] = r_l if c2 == 0.0 else r_l - (2.0 / c2) * (v2 @ r_l) * v2
    return _unit(normals)


def tube(path: np.ndarray, radius: float, sides: int = 12, closed: bool = False) -> TriMesh:
    """A tube of circular section swept along a polyline.

    Parameters
    ----------
    path : (K, 3) array
        Centre line, K >= 2 (>= 3 if closed).
    radius : float
    sides : int
        Vertices around the section.
    closed : bool
        Join the last point to the first (a ring); an open tube gets flat end caps.
    """
    path = np.asarray(path, dtype=np.float64)
    if path.ndim != 2 or path.shape[1] != 3 or len(path) < (3 if closed else 2):
        raise ValueError(f"path must be (K, 3) with K >= {3 if closed else 2}, got {path.shape}")
    if radius <= 0 or sides < 3:
        raise ValueError(f"need radius > 0 and sides >= 3, got {radius} and {sides}")
    tangents = path_tangents(path, closed)
    normals = rotation_minimising_normals(path, tangents)
    binormals = np.cross(tangents, normals)
    angle = 2.0 * np.pi * np.arange(sides) / sides
    cos, sin = np.cos(angle)[None, :, None], np.sin(angle)[None, :, None]
    ring = cos * normals[:, None] + sin * binormals[:, None]  # (K, sides, 3)
    vertices = (path[:, None] + radius * ring).reshape(-1, 3)
    k = len(path)
    i, j = np.meshgrid(np.arange(k if closed else k - 1), np.arange(sides), indexing="ij")
    a = i * sides + j
    b = i * sides + (j + 1) % sides
    c = ((i + 1) % k) * sides + (j + 1) % sides
    d = ((i + 1) % k) * sides + j
    tris = np.concatenate([np.stack([a, b, c], -1), np.stack([a, c, d], -1)]).reshape(-1, 3)
    body = TriMesh(vertices, ring.reshape(-1, 3), tris)
    if closed:
        return body
    caps = [fan(vertices[:sides], -tangents[0]), fan(vertices[-sides:], tangents[-1])]
    return concatenate([body, *caps])


def fan(polygon: np.ndarray, normal: np.ndarray) -> TriMesh:
    """A flat convex polygon (K, 3) triangulated from its centroid, facing ``normal`` (3,)."""
    polygon = np.asarray(polygon, dtype=np.float64)
    centre = polygon.mean(axis=0)
    vertices = np.vstack([centre, polygon])
    k = len(polygon)
    idx = np.arange(k)
    tris = np.stack([np.zeros(k, dtype=np.int64), idx + 1, (idx + 1) % k + 1], axis=1)
    normals = np.broadcast_to(_unit(np.asarray(normal, dtype=np.float64)), vertices.shape)
    return TriMesh(vertices, normals, tris)


def superellipse(half_width: float, half_height: float, exponent: float, n: int) -> np.ndarray:
    """Closed curve ``|x/a|^e + |y/b|^e = 1`` as (n, 2) points, counter-clockwise from +x.

    ``exponent`` 2 gives an ellipse; larger values give a rounded rectangle.
    """
    theta = 2.0 * np.pi * np.arange(n) / n
    c, s = np.cos(theta), np.sin(theta)
    power = 2.0 / exponent
    x = half_width * np.sign(c) * np.abs(c) ** power
    y = half_height * np.sign(s) * np.abs(s) ** power
    return np.stack([x, y], axis=1)


def ellipsoid(
    centre: Sequence[float], radii: Sequence[float], n_lat: int = 24, n_lon: int = 48
) -> TriMesh:
    """A closed ellipsoid mesh with outward normals.

    Parameters
    ----------
    centre : (3,) sequence
    radii : (3,) sequence
        Semi-axes along x, y, z.
    n_lat, n_lon : int
        Rings (pole to pole, poles included) and vertices per ring.
    """
    centre = np.asarray(centre, dtype=np.float64)
    radii = np.asarray(radii, dtype=np.float64)
    lat = np.linspace(0.0, np.pi, n_lat)
    lon = 2.0 * np.pi * np.arange(n_lon) / n_lon
    unit = np.stack(
        [
            np.sin(lat)[:, None] * np.cos(lon)[None],
            np.cos(lat)[:, None] * np.ones_like(lon)[None],
            np.sin(lat)[:, None] * np.sin(lon)[None],
        ],
        axis=-1,
    ).reshape(-1, 3)
    vertices = centre + unit * radii
    normals = _unit(unit / radii)  # gradient of the implicit equation
    i, j = np.meshgrid(np.arange(n_lat - 1), np.arange(n_lon), indexing="ij")
    a = i * n_lon + j
    b = i * n_lon + (j + 1) % n_lon
    c = (i + 1) * n_lon + (j + 1) % n_lon
    d = (i + 1) * n_lon + j
    tris = np.concatenate([np.stack([a, b, c], -1), np.stack([a, c, d], -1)]).reshape(-1, 3)
    return TriMesh(vertices, normals, tris)
