"""The synthetic head: the MediaPipe canonical mesh with 68 iBUG landmarks on it.

The mesh (468 vertices with UVs) is moved into the frame of
``openface_mean68`` (mm, OpenCV axes) by a similarity fitted on eight points
that both mark: eye corners, mouth corners, chin and nose tip (MediaPipe
vertices 33, 133, 362, 263, 61, 291, 152, 4). Each iBUG landmark is then the
point of the mesh surface seen frontally at the OpenFace point's x-y
(:func:`aamcore.pose.mesh.lift_frontal`): a fixed surface point, so its image
under any pose is exact. Jaw landmarks are fixed points too, whereas on a
real face the jaw outline slides with the view; this generator keeps the
ground truth exact instead.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from aamcore.pose.align import align_points
from aamcore.pose.contour import OutlineModel, build_outline_model
from aamcore.pose.head_model import HeadModel, openface68
from aamcore.pose.mesh import Mesh, SurfacePoints, lift_frontal, mediapipe_canonical_mesh

# iBUG-68 landmark -> MediaPipe canonical vertex marking the same spot.
MEDIAPIPE_ANCHORS: dict[int, int] = {36: 33, 39: 133, 42: 362, 45: 263, 48: 61, 54: 291, 8: 152,
                                     30: 4}


@dataclass(frozen=True, eq=False)
class SynthHead:
    """A textured-able head mesh with exact landmark positions.

    Attributes
    ----------
    mesh : Mesh
        MediaPipe canonical mesh in the OpenFace frame (mm, OpenCV axes), with UVs.
    landmarks : SurfacePoints
        The 68 iBUG landmarks on the mesh.
    """

    mesh: Mesh
    landmarks: SurfacePoints

    @property
    def landmarks_3d(self) -> np.ndarray:
        """The 68 landmarks in the head frame, mm, shape (68, 3)."""
        return self.landmarks.positions(self.mesh)

    @property
    def landmark_uvs(self) -> np.ndarray:
        """Texture coordinates (OBJ convention, v up) of the 68 landmarks, shape (68, 2)."""
        assert self.mesh.uvs is not None
        corners = self.mesh.uvs[self.mesh.triangles[self.landmarks.triangle]]  # (68, 3, 2)
        return np.einsum("mk,mkd->md", self.landmarks.bary, corners)

    def outline_model(self) -> OutlineModel:
        """Slices of the mesh through the jaw landmarks (see :mod:`aamcore.pose.contour`)."""
        cached = self.__dict__.get("_outline")
        if cached is None:
            pts = self.landmarks_3d
            cached = build_outline_model(self.mesh, pts[:17, :2], pts[30, :2], np.arange(17),
                                         name="synth_mediapipe_outline")
            object.__setattr__(self, "_outline", cached)
        return cached

    def head_model(self) -> HeadModel:
        """The exact 3D landmarks of this head as a :class:`HeadModel` (scheme ibug68)."""
        return HeadModel("synth_mediapipe68", "ibug68", 68, np.arange(68), self.landmarks_3d,
                         "MediaPipe canonical mesh, landmarks lifted from openface_mean68")


@lru_cache(maxsize=1)
def synth_head() -> SynthHead:
    """The synthetic head (built once per process)."""
    source = mediapipe_canonical_mesh()
    ref = openface68().points
    ibug = list(MEDIAPIPE_ANCHORS)
    to_ref = align_points(source.vertices[[MEDIAPIPE_ANCHORS[i] for i in ibug]], ref[ibug])
    mesh = Mesh(to_ref.apply(source.vertices), source.triangles, source.uvs, "mediapipe_canonical")
    return SynthHead(mesh, lift_frontal(mesh, ref[:, :2]))
