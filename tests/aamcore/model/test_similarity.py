"""aamcore.model.similarity: the one 2D similarity type, on small synthetic point sets."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aamcore.model.similarity import Similarity, apply_pose

POINTS = np.array([[0.0, 0.0], [2.0, 1.0], [-1.0, 3.0]])


def test_scale_angle_and_the_linear_form_agree() -> None:
    sim = Similarity.from_scale_angle(2.0, math.pi / 6, (5.0, -3.0))
    assert sim.scale == pytest.approx(2.0) and sim.angle == pytest.approx(math.pi / 6)
    np.testing.assert_allclose(sim.translation, [5.0, -3.0])
    expected = POINTS @ sim.linear.T + sim.translation
    np.testing.assert_allclose(sim.apply(POINTS), expected)
    np.testing.assert_allclose(np.c_[POINTS, np.ones(3)] @ sim.matrix.T, expected)


def test_the_aam_pose_parameters_are_zero_for_the_identity() -> None:
    assert np.all(Similarity().params == 0)
    t = np.array([0.1, -0.2, 3.0, 4.0])
    assert Similarity.from_params(t) == Similarity(1.1, -0.2, 3.0, 4.0)
    np.testing.assert_allclose(Similarity.from_params(t).params, t)
    np.testing.assert_allclose(apply_pose(t, POINTS), Similarity.from_params(t).apply(POINTS))


def test_inverse_and_composition() -> None:
    a = Similarity.from_scale_angle(1.5, 0.3, (2.0, 1.0))
    b = Similarity.from_scale_angle(0.7, -1.1, (-4.0, 0.5))
    np.testing.assert_allclose((a @ b).apply(POINTS), a.apply(b.apply(POINTS)))
    np.testing.assert_allclose((a @ a.inverse()).apply(POINTS), POINTS, atol=1e-12)
    np.testing.assert_allclose((a.inverse() @ a).params, 0, atol=1e-12)
    with pytest.raises(ValueError, match="scale 0"):
        Similarity(0.0, 0.0).inverse()


def test_scaled_is_the_placement_in_a_scaled_image() -> None:
    sim = Similarity(1.2, 0.4, 10.0, -6.0)
    np.testing.assert_allclose(sim.scaled(0.5).apply(POINTS), 0.5 * sim.apply(POINTS))


def test_a_placement_is_the_estimate_of_its_reference_on_each_shape() -> None:
    from aamcore.model.similarity import Placement

    rng = np.random.default_rng(3)
    reference = rng.normal(size=(20, 2)) + 5.0
    truths = [Similarity.from_scale_angle(s, a, t) for s, a, t in
              [(0.5, 0.3, (3, -2)), (2.0, -1.0, (10, 4)), (1.3, 2.5, (0, 0))]]
    shapes = np.stack([t.apply(reference) + rng.normal(0, 0.01, (20, 2)) for t in truths])
    placement = Placement(reference)
    ab = placement.ab(shapes)
    for k, shape in enumerate(shapes):
        estimate = Similarity.from_estimate(reference, shape)
        np.testing.assert_allclose(ab[k], [estimate.a, estimate.b], atol=1e-12)
        onto = placement.onto(shape)
        np.testing.assert_allclose(onto.matrix, estimate.matrix, atol=1e-9)
        np.testing.assert_allclose(onto.matrix, truths[k].matrix, atol=0.05)
