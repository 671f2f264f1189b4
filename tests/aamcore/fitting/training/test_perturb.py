"""aamcore.fitting.training.perturb: similarity parameters and perturbed starts."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.fitting.shape_space import ShapeSpace
from aamcore.fitting.training.perturb import (
    perturbed_starts,
    place,
    placed_on_no_face,
    similarity_params,
    start_noise,
)


@pytest.fixture(scope="module")
def space(synthetic_faces) -> ShapeSpace:
    return ShapeSpace.train(np.stack([s.points for s in synthetic_faces.train]), 0.98, (0, 1))


def test_parameters_and_placement_are_inverse(space: ShapeSpace) -> None:
    params = np.array([[0.2, 0.3, 50.0, 60.0], [-0.1, -0.5, 10.0, 0.0]])
    shapes = place(np.broadcast_to(space.mean, (2, *space.mean.shape)), params)
    assert np.allclose(similarity_params(space, shapes), params)
    mean, sd = start_noise(space, shapes, shapes)
    assert np.allclose(mean, 0.0) and np.all(sd < 1e-5)


def test_starts_spread_as_asked(space: ShapeSpace, synthetic_faces) -> None:
    truths = np.stack([s.points for s in synthetic_faces.train] * 25)
    rng = np.random.default_rng(0)
    sd = np.array([0.05, 0.1, 2.0, 3.0])
    starts = perturbed_starts(space, truths, np.zeros(4), sd, rng)
    mean, spread = start_noise(space, starts, truths)
    assert np.allclose(spread[:2], sd[:2], rtol=0.15)
    kept = perturbed_starts(space, truths[:5], np.zeros(4), np.zeros(4), rng, shape_sd=0.0)
    assert np.allclose(kept, space.project(truths[:5]), atol=1e-6)


def test_shapes_on_frames_without_a_face_lie_inside_them(space: ShapeSpace) -> None:
    owners, shapes = placed_on_no_face(space, [(200, 100), (50, 80)], 7,
                                       np.random.default_rng(2))
    assert owners.tolist() == [0] * 7 + [1] * 7 and shapes.shape == (14, space.n_points, 2)
    centres = shapes.mean(axis=1)
    assert np.all(centres[:7] < [200, 100]) and np.all(centres[7:] < [50, 80])
