"""Triangle meshes of the face (Surrey reference, MediaPipe canonical) in OpenCV axes.

Every mesh is returned in millimetres with OpenCV camera axes (+x right,
+y down, +z away from a camera that the face looks at), the frame of
``openface_mean68``. The MediaPipe (cm) and Surrey (mm) files use +y up and
+z toward the viewer: a half turn about x (a proper rotation, no mirroring)
takes them to OpenCV axes.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aamcore.config import data_root


@dataclass(frozen=True, eq=False)
class Mesh:
    """A triangle mesh.

    Attributes
    ----------
    vertices : (V, 3) float64 array
        Millimetres, OpenCV axes.
    triangles : (F, 3) int array
        Vertex indices, 0-based.
    uvs : (V, 2) float64 array or None
        Texture coordinates per vertex (OBJ convention: v up), when the file has them.
    name : str
    """

    vertices: np.ndarray
    triangles: np.ndarray
    uvs: np.ndarray | None
    name: str


def load_obj(path: str | Path, mm_per_unit: float = 1.0, y_up: bool = True) -> Mesh:
    """Read vertices, triangles and per-vertex UVs of a Wavefront OBJ file.

    Parameters
    ----------
    path : path
    mm_per_unit : float
        Millimetres per file unit (10 for centimetres).
    y_up : bool
        True if the file uses +y up, +z toward the viewer (converted to OpenCV axes).

    Raises
    ------
    ValueError
        Naming the file, if it has no vertices or triangles, a non-triangle face,
        or a face index out of range.
    """
    path = Path(path)
    verts: list[list[float]] = []
    tex: list[list[float]] = []
    faces: list[list[int]] = []
    face_tex: list[list[int]] = []
    for line in path.read_text().splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            verts.append([float(x) for x in parts[1:4]])
        elif parts[0] == "vt":
            tex.append([float(x) for x in parts[1:3]])
        elif parts[0] == "f":
            if len(parts) != 4:
                raise ValueError(f"{path}: face with {len(parts) - 1} vertices, only triangles")
            refs = [p.split("/") for p in parts[1:]]
            faces.append([int(r[0]) - 1 for r in refs])
            if all(len(r) > 1 and r[1] for r in refs):
                face_tex.append([int(r[1]) - 1 for r in refs])
    if not verts or not faces:
        raise ValueError(f"{path}: no vertices or no triangles")
    V = np.array(verts) * mm_per_unit
    F = np.array(faces, dtype=np.int64)
    if F.min() < 0 or F.max() >= len(V):
        raise ValueError(f"{path}: face index out of range")
    if y_up:
        V = V * np.array([1.0, -1.0, -1.0])
    uvs = None
    if tex and len(face_tex) == len(faces):
        uvs = np.zeros((len(V), 2))
        uvs[F.ravel()] = np.array(tex)[np.array(face_tex).ravel()]
    return Mesh(V, F, uvs, path.stem)


def surrey_reference_mesh() -> Mesh:
    """The 845-vertex Surrey Face Model reference mesh (mm), from the data folder."""
    return load_obj(data_root() / "models3d" / "surrey_sfm" / "sfm_reference.obj", 1.0)


def surrey_ibug_vertices(n_vertices: int = 845) -> dict[int, int]:
    """iBUG-68 landmark (0-based) -> Surrey vertex, from ``ibug_to_sfm.txt``.

    Only vertices below ``n_vertices`` (those of the reference mesh) are kept:
    the file leaves out the jaw contour and the inner mouth corners, and names a
    few vertices that exist only in the finer model.
    """
    path = data_root() / "models3d" / "surrey_sfm" / "ibug_to_sfm.txt"
    try:
        table = tomllib.loads(path.read_text())["landmark_mappings"]
    except (OSError, KeyError, tomllib.TOMLDecodeError) as exc:
        raise ValueError(f"{path}: cannot read the landmark mappings ({exc})") from exc
    return {int(k) - 1: int(v) for k, v in table.items() if int(v) < n_vertices}


def mediapipe_canonical_mesh() -> Mesh:
    """The 468-vertex MediaPipe canonical face mesh with UVs (cm in the file, mm here)."""
    path = data_root() / "models3d" / "mediapipe_canonical" / "canonical_face_model.obj"
    return load_obj(path, 10.0)


@dataclass(frozen=True, eq=False)
class SurfacePoints:
    """Points on a mesh as barycentric combinations of triangle vertices.

    Attributes
    ----------
    triangle : (M,) int array
        Triangle index of each point.
    bary : (M, 3) float64 array
        Barycentric weights, rows summing to 1.
    on_surface : (M,) bool array
        False where the point was off the mesh's frontal outline and was
        snapped to the nearest vertex.
    """

    triangle: np.ndarray
    bary: np.ndarray
    on_surface: np.ndarray

    def positions(self, mesh: Mesh, vertices: np.ndarray | None = None) -> np.ndarray:
        """3D positions, shape (M, 3), on ``mesh`` (or on moved ``vertices`` of it)."""
        V = mesh.vertices if vertices is None else vertices
        corners = V[mesh.triangles[self.triangle]]  # (M, 3, 3)
        return np.einsum("mk,mkd->md", self.bary, corners)


def lift_frontal(mesh: Mesh, xy: np.ndarray) -> SurfacePoints:
    """Lift 2D points seen from the front onto the mesh surface nearest the camera.

    Each point ``(x, y)`` is met by the ray parallel to +z through it; the
    first triangle it crosses (smallest z) gives the surface point. Points
    outside the mesh's frontal outline are snapped to the nearest vertex in x-y.

    Parameters
    ----------
    mesh : Mesh
    xy : (M, 2) array
        Points in the mesh's x-y units (mm).
    """
    xy = np.asarray(xy, dtype=np.float64)
    tri = mesh.vertices[mesh.triangles]  # (F, 3, 3)
    a, b, c = tri[:, 0, :2], tri[:, 1, :2], tri[:, 2, :2]
    v0, v1 = b - a, c - a
    den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]  # (F,)
    ok_tri = np.abs(den) > 1e-12
    den = np.where(ok_tri, den, 1.0)
    d = xy[:, None, :] - a[None]  # (M, F, 2)
    l1 = (d[..., 0] * v1[:, 1] - v1[:, 0] * d[..., 1]) / den
    l2 = (v0[:, 0] * d[..., 1] - d[..., 0] * v0[:, 1]) / den
    l0 = 1.0 - l1 - l2
    eps = -1e-9
    inside = (l0 >= eps) & (l1 >= eps) & (l2 >= eps) & ok_tri
    z = l0 * tri[:, 0, 2] + l1 * tri[:, 1, 2] + l2 * tri[:, 2, 2]
    z = np.where(inside, z, np.inf)
    best = np.argmin(z, axis=1)
    rows = np.arange(len(xy))
    hit = np.isfinite(z[rows, best])
    bary = np.stack([l0[rows, best], l1[rows, best], l2[rows, best]], axis=1)
    triangle = best.copy()
    for m in np.flatnonzero(~hit):
        vertex = int(np.argmin(np.sum((mesh.vertices[:, :2] - xy[m]) ** 2, axis=1)))
        t, k = np.argwhere(mesh.triangles == vertex)[0]
        triangle[m] = t
        bary[m] = np.eye(3)[k]
    return SurfacePoints(triangle, np.clip(bary, 0.0, 1.0), hit)
