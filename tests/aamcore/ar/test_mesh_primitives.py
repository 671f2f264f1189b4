"""Meshes built in code: tubes, fans, superellipses, ellipsoids."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.ar.mesh_primitives import (
    TriMesh,
    concatenate,
    ellipsoid,
    fan,
    path_tangents,
    superellipse,
    tube,
)


def _helix(n: int = 40) -> np.ndarray:
    t = np.linspace(0, 3 * np.pi, n)
    return np.stack([10 * np.cos(t), 10 * np.sin(t), 4 * t], axis=1)


@pytest.mark.parametrize("closed", [False, True])
def test_tube_surface_is_at_the_radius_with_perpendicular_normals(closed: bool) -> None:
    path = _helix() if not closed else np.column_stack([superellipse(20, 12, 3, 50), np.zeros(50)])
    mesh = tube(path, radius=1.5, sides=10, closed=closed)
    body = mesh.vertices[: len(path) * 10].reshape(len(path), 10, 3)
    normals = mesh.normals[: len(path) * 10].reshape(len(path), 10, 3)
    np.testing.assert_allclose(np.linalg.norm(body - path[:, None], axis=2), 1.5, rtol=1e-5)
    np.testing.assert_allclose(np.linalg.norm(normals, axis=2), 1.0, rtol=1e-5)
    tangents = path_tangents(path, closed)
    assert np.abs(np.einsum("ksd,kd->ks", normals, tangents)).max() < 1e-5
    rings = len(path) if closed else len(path) - 1
    caps = 0 if closed else 2 * 10
    assert mesh.n_triangles == 2 * rings * 10 + caps


def test_planar_ring_normals_do_not_twist() -> None:
    outline = np.column_stack([superellipse(25, 18, 3.5, 64), np.full(64, -20.0)])
    mesh = tube(outline, radius=1.0, sides=8, closed=True)
    # In a plane the rotation-minimising normal is the plane's normal all round.
    first_normals = mesh.normals[::8]
    assert np.all(np.abs(np.abs(first_normals[:, 2]) - 1.0) < 1e-5)


def test_bad_tube_input_is_refused() -> None:
    with pytest.raises(ValueError, match="path"):
        tube(np.zeros((1, 3)), 1.0)
    with pytest.raises(ValueError, match="radius"):
        tube(_helix(), 0.0)


def test_superellipse_points_satisfy_its_equation() -> None:
    points = superellipse(25, 18, 3.5, 64)
    value = np.abs(points[:, 0] / 25) ** 3.5 + np.abs(points[:, 1] / 18) ** 3.5
    np.testing.assert_allclose(value, 1.0, rtol=1e-9)


def test_ellipsoid_vertices_and_outward_normals() -> None:
    centre, radii = np.array([1.0, -2.0, 80.0]), np.array([70.0, 100.0, 90.0])
    mesh = ellipsoid(centre, radii, n_lat=12, n_lon=24)
    value = np.sum(((mesh.vertices - centre) / radii) ** 2, axis=1)
    np.testing.assert_allclose(value, 1.0, rtol=1e-5)
    assert np.all(np.einsum("vd,vd->v", mesh.normals, mesh.vertices - centre) > 0)


def test_fan_and_concatenate_keep_indices_valid() -> None:
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    flat = fan(square, np.array([0, 0, -2.0]))
    np.testing.assert_allclose(flat.normals, np.tile([0, 0, -1.0], (5, 1)))
    both = concatenate([flat, tube(_helix(), 1.0)])
    assert both.triangles.max() == len(both.vertices) - 1
    assert both.triangles[flat.n_triangles :].min() == len(flat.vertices)
    with pytest.raises(ValueError, match="out of range"):
        TriMesh(square, square, np.array([[0, 1, 4]]))
