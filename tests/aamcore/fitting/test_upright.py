"""aamcore.fitting.upright: the turned view of a frame and fits mapped back from it."""

from __future__ import annotations

import math

import numpy as np

from aamcore.fitting.result import AAMFit, LandmarkFit
from aamcore.fitting.upright import mapped, roll_of, rotated_view
from aamcore.model.similarity import Similarity


def test_the_view_moves_pixels_as_its_map_moves_points() -> None:
    image = np.zeros((120, 200), np.uint8)
    image[30:33, 150:153] = 255  # a dot centred at (151, 31)
    view, to_view = rotated_view(image, math.radians(30))
    assert view.shape == image.shape
    y, x = np.unravel_index(np.argmax(view), view.shape)
    expected = to_view.apply(np.array([[151.0, 31.0]]))[0]
    assert np.hypot(x - expected[0], y - expected[1]) < 1.5
    # The centre stays; turning by -30 degrees undoes a roll of +30.
    np.testing.assert_allclose(to_view.apply(np.array([[99.5, 59.5]])), [[99.5, 59.5]])
    assert abs(math.degrees(to_view.angle) + 30.0) < 1e-9


def test_a_fit_mapped_there_and_back_is_unchanged() -> None:
    points = np.array([[10.0, 20.0], [30.0, 25.0], [20.0, 40.0]])
    placed = Similarity.from_scale_angle(2.0, math.radians(20), (5.0, 7.0))
    result = LandmarkFit(points, placed, score=-3.0)
    _, to_view = rotated_view(np.zeros((60, 80), np.uint8), math.radians(20))
    there = mapped(result, to_view)
    assert abs(math.degrees(roll_of(there))) < 1e-9  # upright in the view
    back = mapped(there, to_view.inverse())
    np.testing.assert_allclose(back.points, points, atol=1e-9)
    assert abs(roll_of(back) - math.radians(20)) < 1e-9 and back.score == -3.0
    with_c = AAMFit.of_landmarks(result, np.ones(3), np.zeros(5, np.float32), 0.5)
    moved = mapped(with_c, to_view)
    assert isinstance(moved, AAMFit) and moved.c.tolist() == [1, 1, 1] and moved.error == 0.5
    assert result.points is points  # the original is left as it was
