"""Every fitting algorithm on synthetic faces: from a displaced start it comes back.

One test module per algorithm would repeat the same set-up four times; each
algorithm module is imported and exercised here directly, on the synthetic
AAM of ``tests/aamcore/fitting/conftest.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.fitting.algorithm import ALGORITHMS, algorithm_class
from aamcore.fitting.algorithm.base import AlgorithmSettings
from aamcore.fitting.algorithm.fixed_jacobian import FixedJacobian
from aamcore.fitting.algorithm.local_binary import LocalBinary
from aamcore.fitting.algorithm.multi_resolution import MultiResolution, scale_similarity
from aamcore.fitting.algorithm.project_out_ic import ProjectOutInverseCompositional, shape_basis
from aamcore.fitting.algorithm.supervised_descent import SupervisedDescent, model_frame_step
from aamcore.fitting.failure import FailureTest
from aamcore.fitting.training.descent import train_descent
from aamcore.fitting.training.update import scheme_for_level, train_update
from aamcore.model.similarity import Similarity
from tests.aamcore.fitting.conftest import point_error


def displaced(aam, sample, dx: float, dy: float) -> tuple[np.ndarray, Similarity]:
    _, sim = aam.shape.fit_points(sample.points)
    return np.zeros(aam.n_appearance), Similarity(sim.a, sim.b, sim.tx + dx, sim.ty + dy)


def assert_comes_back(algorithm, aam, samples, dx: float = 5.0, dy: float = -4.0) -> None:
    starts, ends = [], []
    for sample in samples:
        c0, start = displaced(aam, sample, dx, dy)
        image = aam.prepare_image(sample.load_image())
        result = algorithm.run(image, c0, start)
        starts.append(point_error(aam.shape_instance(c0, start), sample.points))
        ends.append(point_error(result.points, sample.points))
        assert result.points.shape == sample.points.shape and np.all(np.isfinite(result.c))
        assert len(result.seconds) == result.iterations and result.ok
        assert result.residual.shape == (aam.frame.n_pixels,)
    assert np.mean(ends) < 0.5 * np.mean(starts), (starts, ends)


@pytest.fixture(scope="module")
def update(synthetic_aam, synthetic_faces):
    return train_update(synthetic_aam, synthetic_faces.train, "jacobian", scheme_for_level(0),
                        max_images=20)


def test_the_registry_names_every_algorithm_class() -> None:
    assert algorithm_class("fixed-jacobian") is FixedJacobian
    assert algorithm_class("multi-resolution") is MultiResolution
    assert algorithm_class("project-out-ic") is ProjectOutInverseCompositional
    assert algorithm_class("supervised-descent") is SupervisedDescent
    assert algorithm_class("local-binary") is LocalBinary
    assert len(ALGORITHMS) == 5
    with pytest.raises(ValueError, match="unknown fitting algorithm 'newton'"):
        algorithm_class("newton")


def test_fixed_jacobian_comes_back_and_stops_by_convergence(
    synthetic_aam, synthetic_faces, update
) -> None:
    algorithm = FixedJacobian(synthetic_aam, update)
    assert_comes_back(algorithm, synthetic_aam, synthetic_faces.test)
    sample = synthetic_faces.test[0]
    result = algorithm.run(synthetic_aam.prepare_image(sample.load_image()),
                           *displaced(synthetic_aam, sample, 2, 2))
    assert result.converged and result.errors == sorted(result.errors, reverse=True)
    capped = FixedJacobian(synthetic_aam, update, AlgorithmSettings(max_iterations=1))
    assert capped.run(synthetic_aam.prepare_image(sample.load_image()),
                      *displaced(synthetic_aam, sample, 6, 6)).iterations == 1


def test_multi_resolution_comes_back_from_farther(synthetic_aam, synthetic_faces, update) -> None:
    coarse = train_update(synthetic_aam, synthetic_faces.train, "jacobian", scheme_for_level(1),
                          max_images=20, level=1)
    levels = [FixedJacobian(synthetic_aam, update), FixedJacobian(synthetic_aam, coarse)]
    assert_comes_back(MultiResolution(levels), synthetic_aam, synthetic_faces.test, 8.0, 6.0)
    with pytest.raises(ValueError, match="at least one level"):
        MultiResolution([])


def test_scale_similarity_follows_pyrdown_pixel_centres() -> None:
    sim = Similarity(1.2, 0.1, 40.0, 30.0)
    half = scale_similarity(sim, 0.5)
    point = np.array([[3.0, -2.0]])
    expected = (sim.apply(point) + 0.5) / 2 - 0.5
    np.testing.assert_allclose(half.apply(point), expected)
    np.testing.assert_allclose(scale_similarity(half, 2.0).apply(point), sim.apply(point))


def test_project_out_ic_comes_back(synthetic_aam, synthetic_faces) -> None:
    algorithm = ProjectOutInverseCompositional(synthetic_aam)
    assert_comes_back(algorithm, synthetic_aam, synthetic_faces.test, 3.0, -3.0)


def test_shape_basis_is_orthonormal_and_spans_similarities(synthetic_aam) -> None:
    mean = synthetic_aam.shape.mean_shape
    basis = shape_basis(mean, synthetic_aam.shape.pca.components)
    np.testing.assert_allclose(basis.T @ basis, np.eye(basis.shape[1]), atol=1e-10)
    moved = Similarity(1.05, 0.02, 3.0, -1.0).apply(mean) - mean
    coords = basis[:, :4].T @ moved.ravel()
    np.testing.assert_allclose(basis[:, :4] @ coords, moved.ravel(), atol=1e-9)


def test_supervised_descent_comes_back(synthetic_aam, synthetic_faces, synthetic_mapping) -> None:
    samples = synthetic_faces.train
    cascade = train_descent(synthetic_aam, samples, [None] * len(samples), synthetic_mapping,
                            stages=3, per_image=6, hog_cell=8)
    assert len(cascade.weights) == 3
    algorithm = SupervisedDescent(synthetic_aam, cascade)
    assert_comes_back(algorithm, synthetic_aam, synthetic_faces.test, 4.0, 3.0)
    sample = synthetic_faces.test[1]
    image = synthetic_aam.prepare_image(sample.load_image())
    first = algorithm.run(image, *displaced(synthetic_aam, sample, 4, 3))
    again = algorithm.track(image, first)  # from the previous fit's placement
    assert point_error(again.points, sample.points) < point_error(first.points, sample.points) + 1


def test_model_frame_step_is_the_move_in_the_model_frame() -> None:
    basis = np.eye(6)
    sim = Similarity(2.0, 0.0, 10.0, 5.0)
    shape = sim.apply(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]))
    target = shape + [2.0, 0.0]  # 2 image px = 1 model px to the right
    np.testing.assert_allclose(model_frame_step(basis, shape, target, sim),
                               [1, 0, 1, 0, 1, 0], atol=1e-12)


def test_a_far_off_fit_fails_the_test_of_eq_7_2(synthetic_aam, synthetic_faces, update) -> None:
    failure = FailureTest(synthetic_aam.combined.pca.variances, "eq7.2")
    algorithm = FixedJacobian(synthetic_aam, update, AlgorithmSettings(max_iterations=1))
    sample = synthetic_faces.test[2]
    c = 50 * np.sqrt(synthetic_aam.combined.pca.variances)
    _, sim = synthetic_aam.shape.fit_points(sample.points)
    result = algorithm.run(synthetic_aam.prepare_image(sample.load_image()), c, sim)
    # The algorithm reports what it found; the test (the fitter's) judges it.
    assert result.ok and "3 sigma" in failure(result.c, result.points)
