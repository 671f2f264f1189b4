"""OBJ meshes in OpenCV axes and lifting frontal 2D points onto them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aamcore.pose.mesh import (
    Mesh,
    lift_frontal,
    load_obj,
    mediapipe_canonical_mesh,
    surrey_ibug_vertices,
    surrey_reference_mesh,
)


def test_mediapipe_mesh_in_mm_and_opencv_axes() -> None:
    m = mediapipe_canonical_mesh()
    assert m.vertices.shape == (468, 3) and m.uvs is not None and m.uvs.shape == (468, 2)
    assert np.all((m.uvs >= 0) & (m.uvs <= 1))
    nose, forehead, chin = m.vertices[4], m.vertices[10], m.vertices[152]
    assert nose[2] == pytest.approx(-75.9, abs=0.1)  # 7.59 cm toward the viewer in the file
    assert forehead[1] < nose[1] < chin[1]  # +y down
    assert m.vertices[33, 0] < 0 < m.vertices[263, 0]  # subject's right eye on image left


def test_surrey_mesh_and_landmark_map() -> None:
    m = surrey_reference_mesh()
    assert m.vertices.shape == (845, 3) and m.uvs is None
    mapping = surrey_ibug_vertices()
    assert len(mapping) == 45 and max(mapping.values()) < 845
    assert mapping[30] == 114  # nose tip (iBUG 31, 1-based, in the file)
    assert m.vertices[114, 2] == pytest.approx(m.vertices[:, 2].min())  # the frontmost vertex
    assert len(surrey_ibug_vertices(3448)) > len(mapping)


def test_load_obj_errors(tmp_path: Path) -> None:
    quad = tmp_path / "quad.obj"
    quad.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    with pytest.raises(ValueError, match="only triangles"):
        load_obj(quad)
    empty = tmp_path / "empty.obj"
    empty.write_text("# nothing\n")
    with pytest.raises(ValueError, match="no vertices"):
        load_obj(empty)
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 9\n")
    with pytest.raises(ValueError, match="out of range"):
        load_obj(bad)


def test_lift_picks_the_surface_nearest_the_camera() -> None:
    # Two overlapping unit squares at z = 10 (front) and z = 50 (behind), plus a far one.
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    verts = np.vstack([np.column_stack([square, np.full(4, 50.0)]),
                       np.column_stack([square, np.full(4, 10.0)]),
                       np.column_stack([square + 5, np.full(4, 30.0)])])
    tris = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7], [8, 9, 10], [8, 10, 11]])
    mesh = Mesh(verts, tris, None, "test")
    lifted = lift_frontal(mesh, np.array([[0.3, 0.6], [5.5, 5.2], [20.0, 20.0]]))
    pos = lifted.positions(mesh)
    assert np.allclose(pos[0], [0.3, 0.6, 10.0])
    assert np.allclose(pos[1], [5.5, 5.2, 30.0])
    assert lifted.on_surface.tolist() == [True, True, False]
    assert np.allclose(pos[2], [6.0, 6.0, 30.0])  # snapped to the nearest vertex
    assert np.allclose(lifted.bary.sum(axis=1), 1.0)
