"""aamcore.fitting.occlusion and its training: the test learned on faces with drawn
occluders, its model file part, and a covered mouth scored as covered."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from aamcore.fitting.appearance import AppearanceSampler
from aamcore.fitting.occlusion import (
    FEATURES,
    OcclusionModel,
    OcclusionTest,
    landmark_weights,
    neighbours,
)
from aamcore.fitting.result import AAMFit, LandmarkFit
from aamcore.fitting.training.occlusion import (
    OcclusionTrainConfig,
    draw_occluder,
    train_occlusion,
)
from aamcore.model.similarity import Similarity

MOUTH = [12, 13, 14, 15]
EYES = [5, 6, 7, 8]


@pytest.fixture(scope="module")
def occlusion(synthetic_aam, synthetic_faces) -> OcclusionModel:
    config = OcclusionTrainConfig(faces=40, occluded=3, epochs=100)
    return train_occlusion(synthetic_aam, synthetic_faces.train, None, config)


def _fit(aam, image: np.ndarray, points: np.ndarray) -> AAMFit:
    found = AppearanceSampler(aam).project(aam.prepare_image(image, points), points)
    return AAMFit.of_landmarks(LandmarkFit(points, Similarity()), found.c, found.residual,
                               found.error, texture=found.texture)


def test_the_learned_part_round_trips_and_is_checked(occlusion, synthetic_aam) -> None:
    header, arrays = occlusion.arrays("occ")
    again = OcclusionModel.from_arrays(header, arrays, "occ")
    assert again.threshold == occlusion.threshold and again.n_triangles == len(
        synthetic_aam.frame.triangles)
    assert np.array_equal(again.hidden_weights, occlusion.hidden_weights)
    assert again.report["views"] == 40 * 4 and 0 <= occlusion.threshold <= 1
    assert occlusion.report["training_visible_flagged"] <= 0.05
    with pytest.raises(ValueError, match="occlusion features"):
        OcclusionModel.from_arrays(header | {"features": ["other"]}, arrays, "occ")
    with pytest.raises(ValueError, match="expected \\(T, 4\\)"):
        OcclusionModel(occlusion.centre[:, :2], occlusion.scale, occlusion.hidden_weights,
                       occlusion.hidden_bias, occlusion.output_weights, 0.0, 0.5)
    fewer = OcclusionModel(occlusion.centre[:3], occlusion.scale[:3], occlusion.hidden_weights,
                           occlusion.hidden_bias, occlusion.output_weights, 0.0, 0.5)
    with pytest.raises(ValueError, match="3 triangles"):
        OcclusionTest(fewer, synthetic_aam)


def test_a_covered_mouth_scores_above_the_same_mouth_in_sight(
    occlusion, synthetic_aam, synthetic_faces
) -> None:
    test = OcclusionTest(occlusion, synthetic_aam)
    covered, seen, eyes = [], [], []
    for sample in synthetic_faces.test:
        image, points = sample.load_image(), sample.points
        hidden = image.copy()
        centre = points[MOUTH].mean(axis=0)
        cv2.ellipse(hidden, (int(centre[0]), int(centre[1])), (16, 10), 0, 0, 360,
                    (150, 160, 175), -1)  # a flat, skin-like patch over the mouth
        clean_scores = test.scores(_fit(synthetic_aam, image, points))
        hidden_scores = test.scores(_fit(synthetic_aam, hidden, points))
        covered.append(hidden_scores[MOUTH].mean())
        seen.append(clean_scores[MOUTH].mean())
        eyes.append(hidden_scores[EYES].mean())
        flags = test(_fit(synthetic_aam, hidden, points))
        assert flags.shape == (len(points),) and flags.dtype == bool
    assert np.mean(covered) > np.mean(seen) and np.mean(covered) > np.mean(eyes)


def test_drawn_occluders_cover_part_of_the_face(synthetic_faces) -> None:
    rng = np.random.default_rng(3)
    sample = synthetic_faces.test[0]
    image, points = sample.load_image(), sample.points
    other = synthetic_faces.test[1].load_image()
    for _ in range(12):
        drawn, mask = draw_occluder(image, points, other, rng)
        assert drawn.shape == image.shape and drawn.dtype == np.uint8 and mask.any()
        assert np.any(drawn[mask] != image[mask])
        lo, hi = points.min(axis=0) - 40, points.max(axis=0) + 40
        ys, xs = np.nonzero(mask)
        near = (xs >= lo[0]) & (xs <= hi[0]) & (ys >= lo[1]) & (ys <= hi[1])
        assert near.mean() > 0.5  # over the face, not somewhere else


def test_landmark_weights_and_neighbours(synthetic_aam) -> None:
    frame = synthetic_aam.frame
    weights = landmark_weights(frame, synthetic_aam.scheme.n_points)
    assert weights.shape == (synthetic_aam.scheme.n_points, len(frame.triangles))
    np.testing.assert_allclose(weights.sum(axis=1), 1.0)
    for n, row in enumerate(weights):  # only the triangles with that landmark as a corner
        assert set(np.flatnonzero(row)) == set(np.flatnonzero((frame.triangles == n).any(1)))
    around = neighbours(frame)
    np.testing.assert_allclose(around.sum(axis=1)[around.sum(axis=1) > 0], 1.0)
    assert np.all(np.diag(around) == 0) and len(FEATURES) == 4
    assert math.isfinite(float(around.max()))
