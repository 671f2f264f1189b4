"""aamcore.pose.contour: slices of a head mesh, silhouettes under a pose."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.pose.contour import build_outline_model, segment_argmax, surrey_on, surrey_outline
from aamcore.pose.head_model import openface68
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.rotation import rotation_from_rpy

CAM = CameraIntrinsics.from_fov(640, 480, 60.0)
FRONT = np.array([0.0, 0.0, 600.0])


def test_segment_argmax_takes_the_first_largest_of_each_segment() -> None:
    values = np.array([1.0, 3.0, 2.0, 5.0, 5.0, 0.0, -1.0])
    starts = np.array([0, 3, 5])
    segment = np.array([0, 0, 0, 1, 1, 2, 2])
    assert segment_argmax(values, starts, segment).tolist() == [1, 3, 5]


def test_frontal_silhouette_is_the_jaw() -> None:
    outline = surrey_outline()
    points, normals, index = outline.silhouette(np.eye(3), FRONT, CAM.K)
    jaw = openface68().points[:17, :2]
    assert points.shape == (17, 3) and index.shape == (17,)
    assert np.abs(points[:, :2] - jaw).max() < 3.0  # mm
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0)
    assert normals[0, 0] < -0.9 and normals[16, 0] > 0.9 and normals[8, 1] > 0.9
    assert np.all(outline.slice_of[index] == np.arange(17))


def test_far_side_outline_moves_toward_the_nose_as_the_head_turns() -> None:
    outline = surrey_outline()
    xs = []
    for yaw in (0.0, 30.0, 60.0):
        points, _, _ = outline.silhouette(rotation_from_rpy(0, 0, yaw), FRONT, CAM.K)
        xs.append(points[2, 0])  # the subject's right cheek: the far side at positive yaw
    assert xs[0] < xs[1] < xs[2]  # monotone toward the nose (x = 0)
    assert xs[2] - xs[0] > 20.0


def test_the_surrey_face_is_placed_on_the_head_shape() -> None:
    ref = openface68().points
    placed = surrey_on(ref)
    # Its nose tip region lies in front of the eyes, as the model's does.
    assert placed.vertices[:, 2].min() < ref[36:48, 2].mean() - 15.0
    assert abs(placed.vertices[:, 0].mean()) < 5.0


def test_a_slice_that_misses_the_mesh_is_refused() -> None:
    mesh = surrey_on(openface68().points)
    far = np.array([[400.0, 0.0], [400.0, 10.0], [400.0, 20.0]])
    with pytest.raises(ValueError, match="misses the mesh"):
        build_outline_model(mesh, far, np.array([0.0, 0.0]), inward_fraction=0.0)
