"""aamcore.fitting.appearance: the AAM appearance of given landmarks."""

from __future__ import annotations

import numpy as np

from aamcore.fitting.appearance import AppearanceSampler, GreyRegion
from aamcore.fitting.occlusion import box_of


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


def test_the_box_samples_the_face_as_the_frame_warp_does(synthetic_aam, synthetic_faces) -> None:
    box = box_of(synthetic_aam)
    sample = synthetic_faces.test[1]
    grey = synthetic_aam.prepare_image(sample.load_image())
    sampled = box.sample(grey, sample.points).astype(np.float32)
    assert sampled.shape == box.size and box.margin > 0
    warped = synthetic_aam.warp.warp(grey, sample.points)
    np.testing.assert_array_equal(sampled.ravel()[box.inside], warped)


def test_a_grey_region_of_the_frame_gives_the_same_appearance(synthetic_aam,
                                                              synthetic_faces) -> None:
    sampler = AppearanceSampler(synthetic_aam)
    sample = synthetic_faces.test[2]
    image, points = sample.load_image(), sample.points
    grey = synthetic_aam.prepare_image(image)
    region = GreyRegion(np.ascontiguousarray(grey[5:, 3:]), (3, 5))
    whole = sampler.project_frame(image, points)
    part = sampler.project_frame(image, points, region)
    np.testing.assert_allclose(part.c, whole.c, atol=1e-9)
    assert abs(part.similarity.tx - whole.similarity.tx) < 1e-9
    small = GreyRegion(np.ascontiguousarray(grey[40:50, 40:50]), (40, 40))  # holds no face
    np.testing.assert_allclose(sampler.project_frame(image, points, small).c, whole.c,
                               atol=1e-9)
