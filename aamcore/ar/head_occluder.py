"""The head surface used to hide the parts of the glasses behind it.

The 68 mean landmarks are too sparse to occlude anything, so the face is the
MediaPipe canonical mesh (468 vertices; centimetres, +y up, +z toward the
viewer in the file), converted to millimetres in OpenCV axes and placed on
the OpenFace mean shape by the least-squares similarity between a few points
both mark: the eye corners, nose tip, mouth corners, chin and the top of the
nose bridge. The mesh ends at the ears and the hairline, so an ellipsoid
stands in for the back and sides of the skull. Both are drawn into the depth
buffer only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aamcore.ar.mesh_primitives import TriMesh, concatenate, ellipsoid
from aamcore.pose.align import align_points
from aamcore.pose.mesh import mediapipe_canonical_mesh

MEDIAPIPE_TO_IBUG: dict[int, int] = {
    33: 36,  # right eye, outer corner
    133: 39,  # right eye, inner corner
    362: 42,  # left eye, inner corner
    263: 45,  # left eye, outer corner
    168: 27,  # top of the nose bridge
    1: 30,  # nose tip
    61: 48,  # mouth, right corner
    291: 54,  # mouth, left corner
    152: 8,  # chin
}
"""MediaPipe face-mesh vertex -> iBUG-68 landmark marking the same spot."""

SKULL_CENTRE = (0.0, -20.0, 85.0)
SKULL_RADII = (72.0, 105.0, 100.0)
"""The back-of-head ellipsoid, mm in the mean-head frame: about 145 mm wide and
200 mm from brow to back; its front stays behind the eyes and nose bridge so
it never hides the lenses, and its sides stay inside the glasses' temples."""


@dataclass(frozen=True, eq=False)
class HeadOccluder:
    """The occluding head.

    Attributes
    ----------
    mesh : TriMesh
        Face then skull, mm, mean-head frame.
    n_face_triangles : int
        The first triangles, from the MediaPipe face.
    fit_rms : float
        RMS distance (mm) between the placed MediaPipe points and their iBUG landmarks.
    """

    mesh: TriMesh
    n_face_triangles: int
    fit_rms: float


def _vertex_normals(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    corners = vertices[triangles]
    face = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals = np.zeros_like(vertices)
    for k in range(3):
        np.add.at(normals, triangles[:, k], face)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return normals / np.where(length > 0, length, 1.0)


def place_face_mesh(
    vertices: np.ndarray, landmarks: np.ndarray
) -> tuple[np.ndarray, float]:
    """Move MediaPipe vertices (468, 3) in OpenCV mm onto an iBUG-68 shape (68, 3).

    Returns
    -------
    placed : (468, 3) array
    rms : float
        RMS residual (mm) over :data:`MEDIAPIPE_TO_IBUG`.
    """
    src = vertices[list(MEDIAPIPE_TO_IBUG)]
    dst = landmarks[list(MEDIAPIPE_TO_IBUG.values())]
    fit = align_points(src, dst)
    rms = float(np.sqrt(np.mean(np.sum((fit.apply(src) - dst) ** 2, axis=1))))
    return fit.apply(vertices), rms


def build_head_occluder(landmarks: np.ndarray) -> HeadOccluder:
    """The face mesh placed on ``landmarks`` (68, 3) plus the skull ellipsoid."""
    landmarks = np.asarray(landmarks, dtype=np.float64)
    if landmarks.shape != (68, 3):
        raise ValueError(f"landmarks must be an iBUG-68 (68, 3) shape, got {landmarks.shape}")
    face = mediapipe_canonical_mesh()
    placed, rms = place_face_mesh(face.vertices, landmarks)
    face_mesh = TriMesh(placed, _vertex_normals(placed, face.triangles), face.triangles)
    skull = ellipsoid(SKULL_CENTRE, SKULL_RADII)
    return HeadOccluder(concatenate([face_mesh, skull]), face_mesh.n_triangles, rms)


def mean_head_occluder() -> HeadOccluder:
    """The occluder for the OpenFace mean head, the frame POSIT's pose is given in."""
    from aamcore.pose.head_model import openface68

    return build_head_occluder(openface68().points)
