"""aamcore.fitting.occlusion and its training: the test learned on faces with drawn
occluders, its model file part, a covered mouth scored as covered, landmarks outside the
image flagged, and the occluders drawn."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from aamcore.fitting.appearance import AppearanceSampler
from aamcore.fitting.occluders import (
    DRAWN,
    covered_shares,
    draw_occluder,
    edge_crop,
)
from aamcore.fitting.occlusion import (
    N_FEATURES,
    Discs,
    OcclusionModel,
    OcclusionTest,
    box_of,
    feature_names,
    logits,
    neighbours,
)
from aamcore.fitting.training.occlusion import OcclusionTrainConfig, train_occlusion

MOUTH = [12, 13, 14, 15]
EYES = [5, 6, 7, 8]


@pytest.fixture(scope="module")
def occlusion(synthetic_aam, synthetic_faces) -> OcclusionModel:
    config = OcclusionTrainConfig(faces=40, occluded=3, epochs=60, context=16)
    return train_occlusion(synthetic_aam, synthetic_faces.train, None, config)


def test_the_learned_part_round_trips_and_is_checked(occlusion, synthetic_aam) -> None:
    header, arrays = occlusion.arrays("occ")
    again = OcclusionModel.from_arrays(header, arrays, "occ")
    assert again.threshold == occlusion.threshold
    assert again.n_points == synthetic_aam.scheme.n_points
    for name in OcclusionModel.ARRAYS:
        assert np.array_equal(getattr(again, name), getattr(occlusion, name))
    report = occlusion.report
    assert report["views"] == 40 * 4 and 0 <= occlusion.threshold <= 1
    assert report["threshold_faces"] == 10  # a face in four sets the threshold
    assert report["threshold_views"]["visible_flagged"] <= 0.05
    with pytest.raises(ValueError, match="occlusion features"):
        OcclusionModel.from_arrays(header | {"features": ["other"]}, arrays, "occ")
    with pytest.raises(ValueError, match=f"expected \\(N, {N_FEATURES}\\)"):
        OcclusionModel.from_arrays(header, arrays | {"occ_centre": occlusion.centre[:, :2]},
                                   "occ")
    fewer = {f"occ_{n}": getattr(occlusion, n) for n in OcclusionModel.ARRAYS}
    fewer["occ_centre"], fewer["occ_scale"] = occlusion.centre[:3], occlusion.scale[:3]
    with pytest.raises(ValueError, match="do not fit together"):
        OcclusionModel.from_arrays(header, fewer, "occ")


def test_a_covered_mouth_scores_above_the_same_mouth_in_sight(
    occlusion, synthetic_aam, synthetic_faces
) -> None:
    test = OcclusionTest(occlusion, synthetic_aam)
    sampler = AppearanceSampler(synthetic_aam, test)
    covered, seen, rise_mouth, rise_eyes = [], [], [], []
    inside = np.zeros(synthetic_aam.scheme.n_points, bool)
    for sample in synthetic_faces.test:
        image, points = sample.load_image(), sample.points
        hidden = image.copy()
        centre = points[MOUTH].mean(axis=0)
        cv2.ellipse(hidden, (int(centre[0]), int(centre[1])), (16, 10), 0, 0, 360,
                    (150, 160, 175), -1)  # a flat, skin-like patch over the mouth
        clean = sampler.features(synthetic_aam.prepare_image(image), points)
        over = sampler.features(synthetic_aam.prepare_image(hidden), points)
        covered.append(test.scores(over, inside)[MOUTH].mean())
        seen.append(test.scores(clean, inside)[MOUTH].mean())
        # the first network reads each landmark's own part: the mouth's rises, not the eyes'
        rise = (logits(occlusion, over, test.around, inside)
                - logits(occlusion, clean, test.around, inside))
        rise_mouth.append(rise[MOUTH].mean())
        rise_eyes.append(rise[EYES].mean())
        flags = sampler.project(synthetic_aam.prepare_image(hidden), points).occluded
        assert flags is not None and flags.shape == (len(points),) and flags.dtype == bool
    assert np.mean(covered) > np.mean(seen) and np.mean(rise_mouth) > np.mean(rise_eyes)


def test_landmarks_outside_the_image_are_flagged_and_c_stays_finite(
    occlusion, synthetic_aam, synthetic_faces
) -> None:
    sampler = AppearanceSampler(synthetic_aam, OcclusionTest(occlusion, synthetic_aam))
    sample = synthetic_faces.test[0]
    image, points = sample.load_image(), sample.points
    shifted = points - [points[:, 0].min() + 0.4 * np.ptp(points[:, 0]), 0.0]  # a face cut
    found = sampler.project_frame(image, shifted)
    assert np.all(np.isfinite(found.c)) and np.all(np.isfinite(found.residual))
    assert found.occluded is not None and np.all(found.occluded[shifted[:, 0] < 0])
    tiny = sampler.project_frame(image, points * 0.05)  # a face of a few pixels
    assert np.all(np.isfinite(tiny.c)) and tiny.occluded is not None
    gone = sampler.project_frame(image, points - 1e4)  # wholly outside
    assert np.all(np.isfinite(gone.c)) and np.all(gone.occluded)


def test_discs_read_the_face_and_what_borders_it(synthetic_aam) -> None:
    box = box_of(synthetic_aam)
    discs = Discs.of(synthetic_aam, box)
    n = synthetic_aam.scheme.n_points
    assert discs.inner.shape == (2 * n, synthetic_aam.frame.n_pixels)
    assert discs.outer.shape == (2 * n, box.size[0] * box.size[1])
    np.testing.assert_allclose(discs.inner.sum(axis=1), 1.0, rtol=1e-5)
    np.testing.assert_allclose(discs.outer.sum(axis=1), 1.0, rtol=1e-5)
    # the outline's landmarks read pixels beyond the face in the box
    outline = np.flatnonzero(~np.isin(np.arange(box.size[0] * box.size[1]), box.inside))
    assert discs.outer[:n][:, outline].sum() > 0
    around = neighbours(synthetic_aam.frame, n)
    np.testing.assert_allclose(around.sum(axis=1)[around.sum(axis=1) > 0], 1.0)
    assert np.all(np.diag(around) == 0) and len(feature_names()) == N_FEATURES


@pytest.mark.parametrize("kind", DRAWN)
def test_drawn_occluders_cover_part_of_the_face(kind, synthetic_faces) -> None:
    rng = np.random.default_rng(3)
    sample = synthetic_faces.test[0]
    image, points = sample.load_image(), sample.points
    other = synthetic_faces.test[1].load_image()
    for _ in range(4):
        drawn, mask = draw_occluder(image, points, rng, kind, other)
        assert drawn.shape == image.shape and drawn.dtype == np.uint8 and mask.any()
        assert np.any(drawn[mask] != image[mask])
        lo, hi = points.min(axis=0) - 40, points.max(axis=0) + 40
        ys, xs = np.nonzero(mask)
        near = (xs >= lo[0]) & (xs <= hi[0]) & (ys >= lo[1]) & (ys <= hi[1])
        assert near.mean() > 0.5  # over the face, not somewhere else
    with pytest.raises(ValueError, match="unknown occluder"):
        draw_occluder(image, points, rng, "cloud")


def test_the_frame_edge_hides_the_landmarks_beyond_it(synthetic_faces) -> None:
    rng = np.random.default_rng(5)
    sample = synthetic_faces.test[0]
    image, points = sample.load_image(), sample.points
    for _ in range(4):
        cut, shift = edge_crop(image, points, rng)
        moved = points + shift
        shares = covered_shares(np.zeros(cut.shape[:2], bool), moved)
        h, w = cut.shape[:2]
        outside = (moved[:, 0] < 0) | (moved[:, 0] > w - 1) | (moved[:, 1] < 0) | (
            moved[:, 1] > h - 1)
        assert outside.any() and np.all(shares[outside] >= 0.45)
        assert np.all(shares[~outside & (shares > 0)] < 1.0)
    inside = covered_shares(np.zeros(image.shape[:2], bool), points)
    assert np.all(inside[(points[:, 0] > 20) & (points[:, 1] > 20)] == 0)
