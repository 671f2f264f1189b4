"""aamcore.expression.crop: observations, the canonical frame, the crop, the turn estimate."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.expression.crop import (
    FaceFeatureError,
    FaceObservation,
    aligned_face,
    approximate_yaw_deg,
    canonical_shape,
    canonical_transform,
    check_landmarks,
    grey,
    transform_points,
)
from tests.aamcore.expression.synthetic_faces import face_image, place, unit_face


def test_canonical_transform_puts_the_eyes_level_and_unit_apart() -> None:
    points = place(unit_face(), 73.0, 25.0, (100.0, 80.0))
    shape = canonical_shape(points)
    np.testing.assert_allclose(shape[36:42].mean(0), [-0.5, 0.0], atol=1e-12)
    np.testing.assert_allclose(shape[42:48].mean(0), [0.5, 0.0], atol=1e-12)
    np.testing.assert_allclose(shape, unit_face(), atol=1e-12)  # similarity-invariant
    M = canonical_transform(points, 48.0, (64.0, 48.0))
    np.testing.assert_allclose(transform_points(M, points)[36:42].mean(0), [40.0, 48.0])


def test_coincident_or_missing_landmarks_are_refused() -> None:
    with pytest.raises(FaceFeatureError, match="eye centres"):
        canonical_transform(np.zeros((68, 2)))
    with pytest.raises(FaceFeatureError, match=r"68 iBUG landmarks"):
        check_landmarks(np.zeros((51, 2)))
    bad = unit_face()
    bad[3, 1] = np.nan
    with pytest.raises(FaceFeatureError, match="non-finite"):
        check_landmarks(bad)


def test_observations_hold_the_fit_at_the_precision_of_the_fit_message() -> None:
    image = np.zeros((40, 50), np.uint8)
    points = np.full((68, 2), 1.0 + 1e-9)
    obs = FaceObservation.from_arrays(image, points, np.arange(4, dtype=np.float32), True, "x")
    assert obs.image is image and obs.landmarks.dtype == np.float64
    np.testing.assert_array_equal(obs.landmarks, np.float32(points))  # rounded as published
    assert obs.appearance.tolist() == [0, 1, 2, 3] and obs.fit_failed and obs.fit_reason == "x"
    empty = FaceObservation.from_arrays(image, None, None)
    assert empty.landmarks.shape == (0, 2) and empty.appearance.shape == (0,)


def test_the_crop_has_the_eyes_where_asked_and_is_grey() -> None:
    points = place(unit_face(), 60.0, 10.0, (160.0, 110.0))
    image = np.dstack([face_image(points)] * 3)
    crop, crop_points = aligned_face(image, points, 128, 48.0, 48.0)
    assert crop.shape == (128, 128) and crop.dtype == np.uint8
    np.testing.assert_allclose(crop_points[36:42].mean(0), [40.0, 48.0], atol=1e-9)
    np.testing.assert_allclose(crop_points[42:48].mean(0), [88.0, 48.0], atol=1e-9)
    assert grey(np.zeros((4, 4), np.float64)).dtype == np.uint8


def test_yaw_grows_with_the_nose_offset() -> None:
    assert approximate_yaw_deg(unit_face()) == pytest.approx(0.0, abs=1e-9)
    face = unit_face()
    face[27:36, 0] += 0.2
    left = approximate_yaw_deg(face)
    face[27:36, 0] -= 0.4
    assert 15 < left < 25 and approximate_yaw_deg(face) == pytest.approx(-left)


def test_a_colour_frame_gives_the_crop_of_its_grey_levels_wherever_the_face_lies() -> None:
    """Only the part of a colour frame the crop comes from is made grey: the same crop, to
    the bit, as from the whole frame's grey levels, for a face inside, across the edge or
    beyond the frame, and from four channels."""
    rng = np.random.default_rng(2)
    frame = rng.integers(0, 256, (120, 160, 3)).astype(np.uint8)
    for centre, size, roll in (((80.0, 60.0), 40.0, 5.0), ((5.0, 110.0), 60.0, -20.0),
                               ((-60.0, 30.0), 30.0, 40.0), ((80.0, 60.0), 300.0, 0.0)):
        points = place(unit_face(), size, roll, centre)
        for image in (frame, np.dstack([frame, np.full(frame.shape[:2], 7, np.uint8)])):
            crop = aligned_face(image, points, 128, 48.0, 48.0)[0]
            np.testing.assert_array_equal(crop, aligned_face(grey(image), points, 128, 48.0,
                                                             48.0)[0])
