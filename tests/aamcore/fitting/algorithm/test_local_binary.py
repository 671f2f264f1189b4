"""aamcore.fitting.algorithm.local_binary on synthetic faces: from a start on the face box it
comes back, it tracks, it scores, and bad input gives failed fits or a clear error."""

from __future__ import annotations

import math
from dataclasses import replace

import cv2
import numpy as np
import pytest

from aamcore.detection.boxes import landmark_box
from aamcore.fitting.algorithm.base import AlgorithmSettings
from aamcore.fitting.algorithm.local_binary import BinaryCascade, LocalBinary
from aamcore.fitting.failure import QualityTest
from aamcore.fitting.result import LandmarkFit
from aamcore.model.similarity import Similarity
from tests.aamcore.fitting.conftest import point_error


@pytest.fixture(scope="module")
def method(synthetic_binary, synthetic_aam) -> LocalBinary:
    return LocalBinary(synthetic_binary, synthetic_aam)


def moved(points: np.ndarray, scale: float, angle: float, shift: tuple[float, float]
          ) -> np.ndarray:
    centre = points.mean(axis=0)
    sim = Similarity.from_scale_angle(scale, angle, centre + np.array(shift))
    return sim.apply(points - centre)


def test_from_the_face_box_it_comes_back(method, synthetic_faces, synthetic_mapping) -> None:
    starts, ends = [], []
    for sample in synthetic_faces.test:
        start = synthetic_mapping.place(landmark_box(sample.points), "landmarks")
        start = moved(start, 1.05, 0.05, (4.0, -3.0))
        result = method.fit_shape(sample.load_image(), start)
        starts.append(point_error(start, sample.points))
        ends.append(point_error(result.points, sample.points))
        # coarse and fern stages (2 + 2), the restart from their fit (1 + 2)
        assert type(result) is LandmarkFit and len(result.seconds) == 7
        assert math.isfinite(result.score) and math.isnan(result.confidence)
    assert np.mean(ends) < 0.5 * np.mean(starts), (starts, ends)


def test_it_tracks_and_scores_good_fits_better(method, synthetic_faces) -> None:
    for sample in synthetic_faces.test:
        image = sample.load_image()
        start = moved(sample.points, 1.02, 0.03, (2.0, 1.5))
        result = method.track_points(image, start)
        assert len(result.seconds) == 3  # restart (1), then both fits through the ferns (2)
        assert point_error(result.points, sample.points) < point_error(start, sample.points)
        far = moved(sample.points, 1.0, 0.0, (45.0, 0.0))
        assert method.score(image, sample.points) < method.score(image, far)
        # the similarity places the AAM's mean shape on the landmarks
        placed = result.similarity.apply(method.aam.shape.mean_shape)
        assert point_error(placed, result.points) < 0.2 * np.ptp(result.points[:, 0])


def test_the_restart_keeps_only_the_placement_and_tracking_gives_a_face(
        method, synthetic_binary, synthetic_aam, synthetic_faces) -> None:
    tracking_only = LocalBinary(replace(synthetic_binary, restart=[]), synthetic_aam)
    other = synthetic_faces.test[-1].points
    for sample in synthetic_faces.test[:-1]:
        image = sample.load_image()
        # another face's shape on this one: a start whose shape error tracking would keep
        _, sim = synthetic_aam.shape.fit_points(sample.points)
        _, on_other = synthetic_aam.shape.fit_points(other)
        start = (sim @ on_other.inverse()).apply(other)
        restarted = method.restart(image, start)
        placed = method.restart(image, method.placed_mean(start))
        assert np.allclose(restarted.points, placed.points, atol=1e-6)
        assert len(restarted.seconds) == 3
        # scored where it lies: better than beside the face
        assert restarted.score < method.score(image, restarted.points + [45.0, 0.0])
        both = method.track_points(image, start)
        # a face of the shape model, scored where it lies, and how far its two fits lay apart
        assert np.allclose(method.project(both.points), both.points, atol=0.01)
        assert both.score < method.score(image, both.points + [45.0, 0.0])  # the face missed
        tracked = tracking_only.track_points(image, start)
        iod = np.linalg.norm(both.points[45] - both.points[36]) if len(both.points) > 45 else (
            np.ptp(both.points[:, 0]))
        assert both.disagreement > 0 and math.isfinite(both.disagreement)
        assert math.isnan(tracked.disagreement) and math.isnan(restarted.disagreement)
        assert np.linalg.norm(both.points - tracked.points, axis=1).mean() < iod
    with pytest.raises(ValueError, match="no restart stages"):
        tracking_only.restart(image, start)


def test_run_and_track_follow_the_protocol(method, synthetic_faces, synthetic_aam) -> None:
    sample = synthetic_faces.test[1]
    image = method.prepare(sample.load_image())
    _, sim = synthetic_aam.shape.fit_points(sample.points)
    first = method.run(image, np.zeros(synthetic_aam.n_appearance), sim)
    again = method.track(image, first)
    assert point_error(again.points, sample.points) < 0.1 * np.ptp(sample.points[:, 0])


def test_bad_input_gives_failed_fits(method, synthetic_faces) -> None:
    sample = synthetic_faces.test[0]
    image = sample.load_image()
    black = np.zeros_like(image)
    result = method.track_points(black, sample.points)
    assert result.failed and "no contrast" in result.reason and result.confidence == 0.0
    outside = method.track_points(image, sample.points + [1000.0, 0.0])
    assert outside.failed and "outside the frame" in outside.reason
    assert method.fit_shape(image, sample.points * np.nan).failed
    partly = method.track_points(image[:, :90], sample.points)  # the face cut at x = 90
    assert partly.points.shape == sample.points.shape and np.all(np.isfinite(partly.points))
    assert method.score(image, sample.points + [1000.0, 0.0]) == math.inf
    with pytest.raises(ValueError, match="no pixels"):
        method.prepare(image[:0])
    # a face a few pixels wide: failed with its reason, not a wrong face
    k = 5.0 / method.eye_distance(sample.points)
    tiny = cv2.resize(image, None, fx=k, fy=k, interpolation=cv2.INTER_AREA)
    small = method.fit_shape(tiny, (sample.points + 0.5) * k - 0.5)
    assert small.failed and "too small" in small.reason and small.confidence == 0.0
    for odd in (image[..., 0], image.astype(np.uint16) * 257,
                np.dstack([image, np.full(image.shape[:2], 255, np.uint8)])):
        prepared = method.prepare(odd)
        assert prepared.dtype == np.uint8
        assert point_error(method.track_points(prepared, sample.points).points,
                           sample.points) < 0.1 * np.ptp(sample.points[:, 0])


def test_it_scores_and_the_threshold_judges(synthetic_binary, synthetic_aam,
                                            synthetic_faces) -> None:
    sample = synthetic_faces.test[0]
    far = moved(sample.points, 1.0, 0.0, (45.0, 0.0))
    image = sample.load_image()
    method = LocalBinary(synthetic_binary, synthetic_aam, AlgorithmSettings())
    found = method.track_points(image, far)
    # The method gives its score; the threshold (applied once, by the fitter) fails it.
    assert not found.failed and QualityTest(synthetic_binary.threshold).reason(found.score)


def test_cascade_checks_and_arrays(synthetic_binary) -> None:
    header, arrays = synthetic_binary.arrays("b")
    again = BinaryCascade.from_arrays(header, arrays, "b")
    assert len(again.coarse) == 2 and len(again.tracking) == 2 and len(again.restart) == 1
    assert np.array_equal(again.restart[0].weights, synthetic_binary.restart[0].weights)
    del header["restart"]  # a cascade written before there were restart stages
    assert BinaryCascade.from_arrays(header, arrays, "b").restart == []
    assert again.threshold == synthetic_binary.threshold
    assert np.array_equal(again.quality.weights, synthetic_binary.quality.weights)
    with pytest.raises(ValueError, match="at least one fern stage"):
        BinaryCascade(again.space, again.coarse, [], again.quality, -2.0)
    with pytest.raises(ValueError, match="threshold"):
        BinaryCascade(again.space, again.coarse, again.tracking, again.quality, math.nan)

