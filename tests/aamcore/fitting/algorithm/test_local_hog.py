"""aamcore.fitting.algorithm.local_hog: the canonical canvas and the landmark descriptors."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.fitting.algorithm.local_hog import HogStage, LandmarkHog
from aamcore.model.similarity import Similarity


def test_canvas_puts_the_eye_corners_iod_apart(synthetic_faces, synthetic_aam) -> None:
    mean = synthetic_aam.shape.mean_shape
    unit = float(np.linalg.norm(mean[0] - mean[1]))
    hog = LandmarkHog(mean, 30.0, 16, 2, unit)
    shape = Similarity.from_scale_angle(1.7, 0.4, (80, 75)).apply(mean)
    m = hog.canvas_transform(shape)
    canvas_points = shape @ m[:, :2].T + m[:, 2]
    assert np.linalg.norm(canvas_points[0] - canvas_points[1]) == pytest.approx(30.0)
    assert np.allclose(canvas_points.mean(axis=0), hog.size / 2)
    sample = synthetic_faces.test[0]
    face = sample.load_image()

    def framed(dx: int, dy: int) -> np.ndarray:
        frame = np.full((400, 400, 3), 90, np.uint8)
        frame[100 + dy:100 + dy + face.shape[0], 100 + dx:100 + dx + face.shape[1]] = face
        return frame

    x = hog(framed(0, 0), sample.points + 100)
    assert x.shape == (len(mean) * hog.size_per_landmark,) and x.dtype == np.float32
    # moving the face and the shape together leaves the descriptors as they were
    assert np.allclose(hog(framed(7, 5), sample.points + [107, 105]), x, atol=1e-4)


def test_stage_checks_and_arrays() -> None:
    stage = HogStage(40.0, 32, 2, np.zeros(72, np.float32), np.ones((72, 6), np.float32),
                     np.zeros(6, np.float32))
    again = HogStage.from_arrays(stage.arrays("h"), "h")
    assert (again.iod, again.window, again.cells) == (40.0, 32, 2)
    assert np.array_equal(again.weights, stage.weights)
    with pytest.raises(ValueError, match="not usable"):
        HogStage(40.0, 30, 4, stage.feature_mean, stage.weights, stage.bias)
    with pytest.raises(ValueError, match="do not fit"):
        HogStage(40.0, 32, 2, stage.feature_mean[:-1], stage.weights, stage.bias)
