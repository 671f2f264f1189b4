"""Which landmarks a camera sees: surface normals of a head model and a visibility ramp.

At large yaw the far-side brow ends and eye corners are on skin that turns
away from the camera; a tracker can only guess where they are.
:func:`landmark_normals` gives the outward surface normal at each of a
68-point head model's landmarks (from the Surrey reference face aligned to
the model), and :func:`visibility_weights` turns the angle between a normal
and the line of sight into a weight, 1 while the point faces the camera well
enough and falling to 0 as its surface turns edge-on.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from aamcore.pose.contour import surrey_on
from aamcore.pose.errors import PoseError
from aamcore.pose.head_model import HeadModel
from aamcore.pose.mesh import lift_frontal


def _vertex_normals(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Unit area-weighted vertex normals (V, 3) of a mesh with vertices V and triangles F."""
    face_n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    vertex_n = np.zeros_like(V)
    for k in range(3):
        np.add.at(vertex_n, F[:, k], face_n)
    vertex_n /= np.maximum(np.linalg.norm(vertex_n, axis=1, keepdims=True), 1e-12)
    # Out of the face means toward the camera that faces it (-z).
    return -vertex_n if np.mean(vertex_n[:, 2]) > 0 else vertex_n


@lru_cache(maxsize=4)
def _surrey_normals(reference: bytes) -> np.ndarray:
    """Unit surface normals (68, 3) of the Surrey reference face at a 68-point head shape."""
    ref = np.frombuffer(reference, dtype=np.float64).reshape(68, 3)
    mesh = surrey_on(ref)
    vertex_n = _vertex_normals(mesh.vertices, mesh.triangles)
    surface = lift_frontal(mesh, ref[:, :2])
    n = np.einsum("mk,mkd->md", surface.bary, vertex_n[mesh.triangles[surface.triangle]])
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)


def landmark_normals(model: HeadModel) -> np.ndarray:
    """Outward surface normals at a 68-point head model's landmarks.

    The Surrey reference face, aligned to the model by a similarity, gives the
    normal of the surface seen frontally at each landmark's x-y.

    Parameters
    ----------
    model : HeadModel
        A full iBUG-68 model.

    Returns
    -------
    (68, 3) float64 array
        Unit normals in the model's frame, in iBUG order.

    Raises
    ------
    PoseError
        If the model is not a full iBUG-68 model.
    """
    if model.scheme != "ibug68" or len(model.indices) != 68:
        raise PoseError(f"visibility needs a full iBUG-68 model, got {model.name}")
    points = model.points[np.argsort(model.indices)]
    return _surrey_normals(np.ascontiguousarray(points, dtype=np.float64).tobytes())


def visibility_weights(
    points: np.ndarray, normals: np.ndarray, R: np.ndarray, T: np.ndarray,
    visible_until_deg: float = 65.0, hidden_from_deg: float = 90.0,
) -> np.ndarray:
    """How well the camera sees each point: 1, falling to 0 as its surface turns away.

    Parameters
    ----------
    points, normals : (N, 3) arrays
        Model points and their unit outward normals, model frame.
    R, T : (3, 3) and (3,) arrays
        Model-to-camera pose.
    visible_until_deg, hidden_from_deg : float
        The weight falls linearly in the cosine of the angle between the
        normal and the direction to the camera, from 1 at ``visible_until_deg``
        to 0 at ``hidden_from_deg``.

    Returns
    -------
    (N,) float64 array in [0, 1]
    """
    cos_full = np.cos(np.radians(visible_until_deg))
    cos_zero = np.cos(np.radians(hidden_from_deg))
    P = points @ R.T + T
    n = normals @ R.T
    to_cam = -P / np.linalg.norm(P, axis=1, keepdims=True)
    cos = np.einsum("nd,nd->n", n, to_cam)
    return np.clip((cos - cos_zero) / (cos_full - cos_zero), 0.0, 1.0)
