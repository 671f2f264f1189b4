"""The face outline of a 3D head seen under a pose: where the jaw landmarks really lie.

The 17 iBUG jaw landmarks (0-16) are not fixed points of the face: an
annotator, and a tracker trained on annotations, puts them on the outline of
the face as seen, which slides over the skin as the head turns. On the far
side of a turned head the outline is the cheek's occluding contour; on the
near side it moves back toward the ear.

:class:`OutlineModel` holds, for each outline landmark, a *slice* of a head
mesh: the front surface's profile in the plane through the landmark's frontal
position that contains the viewing axis (z) and the outline's outward normal.
Under a pose, the landmark lies where that slice's image reaches furthest in
the outward direction (landmark marching, Zhu et al., CVPR 2015). For
estimation only the outline's normal direction is informative: along the
outline the landmark may slide freely; :meth:`OutlineModel.silhouette`
returns both the silhouette point and that direction. The support function
``max_k u_k . d`` has, by the envelope theorem, the gradient of its maximiser,
so a Gauss-Newton step can treat the chosen point as fixed.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from aamcore.pose.align import align_points
from aamcore.pose.mesh import Mesh, surrey_ibug_vertices, surrey_reference_mesh

JAW = tuple(range(17))
"""iBUG-68 indices of the outline landmarks."""


@dataclass(frozen=True, eq=False)
class OutlineModel:
    """Candidate 3D points of the outline landmarks: one slice of the head per landmark.

    Attributes
    ----------
    landmarks : (L,) int array
        iBUG indices of the outline landmarks (``0..16``).
    candidates : (K, 3) float64 array
        All slices' points, slice after slice, mm, head frame.
    starts : (L,) int array
        Index of each slice's first candidate (slices are contiguous).
    outward : (L, 3) float64 array
        Unit outward normal of the frontal outline at each landmark (z = 0).
    frontal : (L, 3) float64 array
        The landmark's point on the slice seen from the front.
    name : str
    """

    landmarks: np.ndarray
    candidates: np.ndarray
    starts: np.ndarray
    outward: np.ndarray
    frontal: np.ndarray
    name: str = ""

    def __post_init__(self) -> None:
        sizes = np.diff(np.append(self.starts, len(self.candidates)))
        object.__setattr__(self, "_slice_of", np.repeat(np.arange(len(self.starts)), sizes))

    @property
    def slice_of(self) -> np.ndarray:
        """(K,) int array: the slice each candidate belongs to."""
        return self._slice_of  # type: ignore[attr-defined]

    def silhouette(
        self, R: np.ndarray, T: np.ndarray, K: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The outline landmarks' 3D points and image normals under a pose.

        Parameters
        ----------
        R : (3, 3) array
            Head-to-camera rotation.
        T : (3,) array
            Head origin in the camera frame, mm.
        K : (3, 3) array
            Camera matrix (no distortion: pass normalised or undistorted points).

        Returns
        -------
        points : (L, 3) array
            The candidate of each slice that reaches furthest outward in the image.
        normals : (L, 2) array
            Unit outward directions of the outline in the image at those points.
        index : (L,) int array
            Row of each point in :attr:`candidates`.
        """
        P = self.candidates @ R.T + T
        z = np.maximum(P[:, 2], 1e-6)
        uv = (P[:, :2] / z[:, None]) @ K[:2, :2].T
        # Outward image direction of each slice: the projected outward normal at its
        # frontal point (perspective: the difference of two projected points).
        F = self.frontal @ R.T + T
        G = (self.frontal + 10.0 * self.outward) @ R.T + T
        d = (G[:, :2] / G[:, 2:3] - F[:, :2] / F[:, 2:3]) @ K[:2, :2].T
        d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
        seg = self.slice_of
        reach = uv[:, 0] * d[seg, 0] + uv[:, 1] * d[seg, 1]
        index = segment_argmax(reach, self.starts, seg)
        return self.candidates[index], d, index


def segment_argmax(values: np.ndarray, starts: np.ndarray, segment: np.ndarray) -> np.ndarray:
    """Index of the (first) largest value in each contiguous segment of ``values``.

    Parameters
    ----------
    values : (K,) array
    starts : (L,) int array
        First index of each segment.
    segment : (K,) int array
        Segment of each value.

    Returns
    -------
    (L,) int array
    """
    best = np.maximum.reduceat(values, starts)
    idx = np.flatnonzero(values >= best[segment])
    seg = segment[idx]
    first = np.ones(len(idx), dtype=bool)
    first[1:] = seg[1:] != seg[:-1]
    return idx[first]


def _outward_normals(xy: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Unit normals (L, 2) of the polyline ``xy`` (L, 2) pointing away from ``centre`` (2,)."""
    tangent = np.gradient(xy, axis=0)
    normal = np.column_stack([tangent[:, 1], -tangent[:, 0]])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    flip = np.einsum("ld,ld->l", normal, xy - centre) < 0
    normal[flip] *= -1.0
    return normal


def _mesh_edges(mesh: Mesh) -> np.ndarray:
    """The mesh's distinct edges, (E, 2) vertex indices."""
    e = np.sort(mesh.triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    return np.unique(e, axis=0)


def _slice_profile(
    a: np.ndarray, b: np.ndarray, p: np.ndarray, n: np.ndarray, reach_in: float,
    outward_mm: float, bin_mm: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The front-most surface points of one slice, and the slice's point nearest ``p``.

    Parameters
    ----------
    a, b : (E, 3) arrays
        End points of the mesh's edges.
    p, n : (2,) arrays
        The landmark's frontal x-y and the outline's outward unit normal there.
    reach_in, outward_mm : float
        How far the slice reaches inward and outward of ``p`` along ``n``, mm.
    bin_mm : float
        Sampling step along the slice.

    Returns
    -------
    profile : (P, 3) array
        One point per bin, ordered along the slice; empty when the slice misses the mesh.
    frontal : (3,) array
        The profile point nearest ``p`` along the slice (undefined for an empty profile).
    """
    t = np.array([-n[1], n[0]])
    da = (a[:, :2] - p) @ t
    db = (b[:, :2] - p) @ t
    cross = (da * db <= 0) & (da != db)
    w = da[cross] / (da[cross] - db[cross])
    hits = a[cross] + w[:, None] * (b[cross] - a[cross])
    s = (hits[:, :2] - p) @ n
    keep = (s >= -reach_in) & (s <= outward_mm)
    hits, s = hits[keep], s[keep]
    if len(hits) == 0:
        return hits, np.zeros(3)
    bins = np.floor(s / bin_mm).astype(np.int64)
    order = np.lexsort((hits[:, 2], bins))  # by bin, then front-most (smallest z) first
    bins, hits, s = bins[order], hits[order], s[order]
    first = np.ones(len(bins), dtype=bool)
    first[1:] = bins[1:] != bins[:-1]
    profile = hits[first]
    return profile, profile[int(np.argmin(np.abs(s[first])))]


def build_outline_model(
    mesh: Mesh,
    outline_xy: np.ndarray,
    centre_xy: np.ndarray,
    landmarks: np.ndarray | None = None,
    inward_fraction: float = 0.9,
    outward_mm: float = 2.0,
    bin_mm: float = 1.5,
    name: str = "",
) -> OutlineModel:
    """Slice a head mesh through each outline landmark.

    Parameters
    ----------
    mesh : Mesh
        Head surface in the head frame (mm, OpenCV axes: the face looks toward -z).
    outline_xy : (L, 2) array
        Frontal x-y of the outline landmarks, in order along the outline.
    centre_xy : (2,) array
        A point inside the face (e.g. the nose); outward points away from it.
    landmarks : (L,) int array, optional
        Their iBUG indices (default ``0..L-1``).
    inward_fraction : float
        How far toward ``centre_xy`` a slice reaches, as a fraction of the
        landmark's distance from it: the far side's outline can move to the nose.
    outward_mm : float
        How far beyond the frontal landmark a slice reaches: the frontal
        outline is where the face ends (a mesh that goes on to the neck or ears
        must not pull the jaw points there).
    bin_mm : float
        Sampling step along a slice; each step keeps the front-most surface point.
    name : str

    Raises
    ------
    ValueError
        If a slice misses the mesh.
    """
    xy = np.asarray(outline_xy, dtype=np.float64)
    centre = np.asarray(centre_xy, dtype=np.float64)
    normals = _outward_normals(xy, centre)
    edges = _mesh_edges(mesh)
    a, b = mesh.vertices[edges[:, 0]], mesh.vertices[edges[:, 1]]
    chunks, starts, frontal = [], [], []
    count = 0
    for p, n in zip(xy, normals, strict=True):
        reach_in = inward_fraction * float((p - centre) @ n)
        profile, front = _slice_profile(a, b, p, n, reach_in, outward_mm, bin_mm)
        if len(profile) == 0:
            raise ValueError(f"outline slice at {p.round(1).tolist()} misses the mesh {mesh.name}")
        chunks.append(profile)
        starts.append(count)
        count += len(profile)
        frontal.append(front)
    outward = np.column_stack([normals, np.zeros(len(normals))])
    idx = np.arange(len(xy)) if landmarks is None else np.asarray(landmarks, dtype=np.int64)
    return OutlineModel(idx, np.vstack(chunks), np.array(starts), outward, np.array(frontal),
                        name)


def surrey_on(reference: np.ndarray) -> Mesh:
    """The Surrey reference face moved onto a 68-point head shape.

    Parameters
    ----------
    reference : (68, 3) array
        iBUG-68 head shape, mm, OpenCV axes.

    Returns
    -------
    Mesh
        The 845-vertex Surrey reference mesh after the 3D similarity that maps
        its iBUG vertices (``ibug_to_sfm.txt``) onto ``reference``.
    """
    mesh = surrey_reference_mesh()
    vertex_of = surrey_ibug_vertices(len(mesh.vertices))
    mapped = sorted(vertex_of)
    to_ref = align_points(mesh.vertices[[vertex_of[i] for i in mapped]],
                                  reference[mapped])
    return Mesh(to_ref.apply(mesh.vertices), mesh.triangles, mesh.uvs, "surrey_placed")


@lru_cache(maxsize=4)
def surrey_outline(reference_points: bytes | None = None) -> OutlineModel:
    """The outline model of the Surrey reference mesh placed on a head shape.

    The 845-vertex Surrey reference face is moved into the frame of
    :func:`aamcore.pose.head_model.openface68` (or of the given shape) by
    :func:`surrey_on` and sliced through its jaw points (iBUG 0-16), outward
    from the nose (iBUG 30).

    Parameters
    ----------
    reference_points : bytes, optional
        A (68, 3) float64 iBUG head shape as bytes (a cache key) to align to
        instead of OpenFace's.
    """
    from aamcore.pose.head_model import openface68

    ref = (openface68().points if reference_points is None
           else np.frombuffer(reference_points, dtype=np.float64).reshape(68, 3))
    return build_outline_model(surrey_on(ref), ref[:17, :2], ref[30, :2], np.arange(17),
                               name="surrey_reference_outline")
