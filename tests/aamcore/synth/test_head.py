"""The synthetic head: MediaPipe mesh in the OpenFace frame with 68 landmarks."""

from __future__ import annotations

import numpy as np

from aamcore.pose.head_model import openface68
from aamcore.synth.head import MEDIAPIPE_ANCHORS, synth_head


def test_mesh_is_in_the_openface_frame() -> None:
    head = synth_head()
    ref = openface68().points
    anchors = head.mesh.vertices[list(MEDIAPIPE_ANCHORS.values())]
    assert np.max(np.linalg.norm(anchors - ref[list(MEDIAPIPE_ANCHORS)], axis=1)) < 6.0  # mm


def test_landmarks_lie_on_the_mesh_below_the_openface_points() -> None:
    head = synth_head()
    ref = openface68().points
    pts = head.landmarks_3d
    on = head.landmarks.on_surface
    assert on.sum() >= 65  # a few jaw points may fall just outside the mesh outline
    assert np.allclose(pts[on, :2], ref[on, :2], atol=1e-9)
    assert np.max(np.abs(pts[:, 2] - ref[:, 2])) < 20.0  # depth from the mesh, mm
    uv = head.landmark_uvs
    assert np.all((uv >= 0) & (uv <= 1))
    model = head.head_model()
    assert model.scheme == "ibug68" and np.allclose(model.points, pts)


def test_the_outline_model_slices_the_mesh_through_the_jaw() -> None:
    head = synth_head()
    outline = head.outline_model()
    assert outline is head.outline_model()  # built once
    assert outline.landmarks.tolist() == list(range(17)) and len(outline.starts) == 17
    points, _, _ = outline.silhouette(np.eye(3), np.array([0.0, 0.0, 600.0]), np.eye(3))
    assert np.abs(points[:, :2] - head.landmarks_3d[:17, :2]).max() < 3.0
