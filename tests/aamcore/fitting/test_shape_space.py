"""aamcore.fitting.shape_space: the basis, the similarity, the projection, the steps."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.fitting.shape_space import ShapeSpace
from aamcore.model.similarity import Similarity


@pytest.fixture(scope="module")
def space(synthetic_faces) -> ShapeSpace:
    shapes = np.stack([s.points for s in synthetic_faces.train])
    return ShapeSpace.train(shapes, 0.98, (0, 1))


def test_basis_is_orthonormal_and_starts_with_the_similarity(space: ShapeSpace) -> None:
    q = space.basis.shape[1]
    assert q == 4 + space.modes.shape[1]
    assert np.allclose(space.basis.T @ space.basis, np.eye(q), atol=1e-10)
    # a scaled, rotated, shifted mean lies in the span of the first four directions
    moved = Similarity.from_scale_angle(1.3, 0.2, (5, -3)).apply(space.mean) - space.mean
    first = space.basis[:, :4]
    assert np.allclose(first @ (first.T @ moved.ravel()), moved.ravel(), atol=1e-9)
    assert abs(np.linalg.norm(space.mean.mean(axis=0))) < 1e-9


def test_similarity_and_projection_of_placed_shapes(space: ShapeSpace) -> None:
    sim = Similarity.from_scale_angle(0.8, -0.3, (60, 70))
    placed = sim.apply(space.mean)[None]
    assert np.allclose(space.similarity(placed)[0], [sim.a, sim.b])
    assert np.allclose(space.project(placed), placed, atol=1e-9)
    wild = placed + np.random.default_rng(0).normal(0, 30, placed.shape)
    projected = space.project(wild)
    again = space.project(projected)
    # nearly a fixed point (the modes are nearly orthogonal to the similarity directions)
    assert np.abs(again - projected).max() < 0.01 * np.abs(projected - wild).max()


def test_steps_move_shapes_onto_their_targets(space: ShapeSpace) -> None:
    sims = [Similarity.from_scale_angle(s, a, (x, y))
            for s, a, x, y in [(1.0, 0.0, 50, 50), (1.4, 0.3, 80, 60)]]
    shapes = np.stack([s.apply(space.mean) for s in sims])
    truths = shapes + np.array([3.0, -2.0])  # a shift: in the span of the basis
    steps = space.step_targets(shapes, truths)
    assert steps.shape == (2, space.basis.shape[1])
    assert np.allclose(space.apply_steps(shapes, steps, project=False), truths, atol=1e-9)


def test_arrays_round_trip_and_checks(space: ShapeSpace) -> None:
    again = ShapeSpace.from_arrays(space.arrays("s"), "s")
    for name in ("mean", "modes", "limits", "basis"):
        assert np.array_equal(getattr(again, name), getattr(space, name))
    assert again.eye_corners == (0, 1) and again.eye_distance == pytest.approx(space.eye_distance)
    broken = space.arrays("s")
    broken["s_limits"] = broken["s_limits"][:-1]
    with pytest.raises(ValueError, match="disagree"):
        ShapeSpace.from_arrays(broken, "s")
    with pytest.raises(ValueError, match="eye corners"):
        ShapeSpace(space.mean, space.modes, space.limits, space.basis, (0, 99))
