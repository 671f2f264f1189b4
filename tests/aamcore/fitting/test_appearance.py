"""aamcore.fitting.appearance: the AAM appearance of given landmarks."""

from __future__ import annotations

import numpy as np

from aamcore.fitting.appearance import AppearanceSampler


def test_appearance_of_true_landmarks_matches_the_model(synthetic_aam, synthetic_faces) -> None:
    sampler = AppearanceSampler(synthetic_aam)
    sample = synthetic_faces.test[0]
    image = sample.load_image()
    c, error = sampler(image, sample.points)
    assert c.shape == (synthetic_aam.n_appearance,) and np.all(np.isfinite(c))
    expected, _ = synthetic_aam.parameters_of(image, sample.points)
    assert np.linalg.norm(c - expected) < 0.05 * np.linalg.norm(expected) + 1e-6
    _, off = sampler(image, sample.points + [6.0, 4.0])
    assert 0.0 <= error < off
