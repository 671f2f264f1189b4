import numpy as np

from aamcore.model.procrustes import (
    generalised_procrustes,
    procrustes_distance,
)
from aamcore.model.similarity import Similarity


def _random_similarity(rng: np.random.Generator) -> Similarity:
    return Similarity.from_scale_angle(
        rng.uniform(0.5, 2.0), rng.uniform(-np.pi, np.pi), rng.uniform(-100, 100, 2)
    )


def test_align_recovers_similarity(imm_set) -> None:
    rng = np.random.default_rng(0)
    shape = imm_set.samples[0].points
    sim = _random_similarity(rng)
    found = Similarity.from_estimate(shape, sim.apply(shape))
    assert found.scale == np.float64(sim.scale) or abs(found.scale - sim.scale) < 1e-9
    np.testing.assert_allclose(found.apply(shape), sim.apply(shape), atol=1e-8)
    np.testing.assert_allclose(found.inverse().apply(sim.apply(shape)), shape, atol=1e-8)


def test_gpa_converges_and_is_similarity_invariant(imm_set) -> None:
    shapes = np.stack([s.points for s in imm_set.samples[:40]])
    aligned, mean, iterations = generalised_procrustes(shapes)
    assert iterations < 20
    assert np.linalg.norm(mean) == np.float64(1.0) or abs(np.linalg.norm(mean) - 1) < 1e-12
    rng = np.random.default_rng(1)
    moved = np.stack([_random_similarity(rng).apply(s) for s in shapes])
    aligned2, mean2, _ = generalised_procrustes(moved)
    assert procrustes_distance(mean2, mean) < 1e-6
    d1 = [procrustes_distance(a, mean) for a in aligned]
    d2 = [procrustes_distance(a, mean2) for a in aligned2]
    np.testing.assert_allclose(d1, d2, atol=1e-6)
    # Aligned shapes are closer to each other than the raw ones.
    assert (
        np.var(aligned, axis=0).sum()
        < np.var(moved / np.linalg.norm(moved, axis=(1, 2))[:, None, None], axis=0).sum()
    )
