"""aamcore.expression.streams: stream-order sequences, moved frames, the per-opening scores."""

from __future__ import annotations

import numpy as np

from aamcore.expression.streams import (
    HOLD,
    OPENING_HOLD,
    SHIFT_PX,
    StreamScores,
    _score,
    format_streams,
    moved,
    stream_order,
)
from aamcore.expression.training import JaffeFaces
from tests.aamcore.expression.synthetic_faces import expression_observation


def _faces() -> JaffeFaces:
    kinds = ["NE", "HA", "SU", "NE", "HA", "SU"]
    posers = ["A"] * 3 + ["B"] * 3
    observations = [expression_observation(k, 0.0) for k in kinds]
    return JaffeFaces(observations, np.array(kinds), np.array(posers),
                      np.array([f"{p}.{k}" for p, k in zip(posers, kinds, strict=True)]))


def test_a_stream_opens_on_its_expression_then_shows_the_others() -> None:
    faces = _faces()
    frames = stream_order(faces, "B", "HA")
    assert frames[:OPENING_HOLD] == [4] * OPENING_HOLD
    assert frames[OPENING_HOLD:] == [5] * HOLD + [3] * HOLD  # SU, then (after FE..DI) NE
    assert set(frames) == {3, 4, 5}


def test_a_moved_frame_carries_its_landmarks_with_it() -> None:
    obs = expression_observation("NE", 0.0)
    shifted = moved(obs, np.random.default_rng(1))
    d = shifted.landmarks - obs.landmarks
    assert np.allclose(d, d[0]) and np.all(np.abs(d[0]) <= SHIFT_PX)
    assert shifted.image.shape == obs.image.shape and shifted.image.dtype == np.uint8


def test_scores_count_unlabelled_frames_as_wrong_and_flicker_within_an_image() -> None:
    out = StreamScores({"r": {"NE": 0}}, {"r": {"NE": 0}}, {"r": []}, {"r": []}, {"r": 0})
    truth = np.array(["NE", "HA"])
    _score(out, "r", "NE", [0, 0, 0, 1], truth,
           [("NE", 0.9), ("HA", 0.6), (None, 0.0), ("HA", 0.8)])
    assert out.total["r"]["NE"] == 4 and out.right["r"]["NE"] == 2
    assert out.changes["r"] == 1 and out.rate("r") == 0.5
    mean_p, accuracy, bins = out.calibration("r")
    assert np.isclose(mean_p, (0.9 + 0.6 + 0.8) / 3) and np.isclose(accuracy, 2 / 3)
    assert "| r | 50.0 |" in format_streams(out, ["NE"])
