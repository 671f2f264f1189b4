"""aamcore.expression.analysis: one face's gate and feature blocks, and many faces at once."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from aamcore.expression.analysis import analyse_face, face_problem, feature_vector, observe
from aamcore.expression.crop import FaceFeatureError, FaceObservation, transform_points
from aamcore.expression.spec import FeatureConfig, QualityLimits
from tests.aamcore.expression.synthetic_faces import observation

ALL = FeatureConfig(blocks=("hog", "shape", "appearance"))


def test_block_lengths_match_the_config() -> None:
    problem, blocks = analyse_face(observation(), ALL)
    assert problem == "" and blocks is not None and list(blocks) == list(ALL.blocks)
    assert ALL.block_dims(5) == {"hog": 51 * 4 * 9, "shape": 136, "appearance": 5}
    assert {k: v.shape for k, v in blocks.items()} == {k: (d,) for k, d in
                                                       ALL.block_dims(5).items()}
    vector = feature_vector(blocks, ALL)
    assert vector.shape == (1977,) and np.isfinite(vector).all()
    np.testing.assert_array_equal(blocks["appearance"], np.arange(5.0))


def test_features_are_nearly_invariant_to_where_and_how_large_the_face_is() -> None:
    config = FeatureConfig()
    obs = observation()
    M = cv2.getRotationMatrix2D((150.0, 100.0), 8.0, 1.25)
    moved = FaceObservation.from_arrays(cv2.warpAffine(obs.image, M, (320, 240)),
                                        transform_points(M, obs.landmarks), None)
    a, b = analyse_face(obs, config)[1], analyse_face(moved, config)[1]
    assert a is not None and b is not None
    np.testing.assert_allclose(a["shape"], b["shape"], atol=1e-5)  # float32 landmarks
    similarity = a["hog"] @ b["hog"] / (np.linalg.norm(a["hog"]) * np.linalg.norm(b["hog"]))
    assert similarity > 0.9  # not 1: the pixel noise is resampled


def test_refused_faces_have_a_reason_and_no_blocks() -> None:
    obs = observation()
    half = obs.image.copy()
    half[:, 160:] = np.random.default_rng(3).integers(0, 255, half[:, 160:].shape)
    one_sided = FaceObservation.from_arrays(half, obs.landmarks, None)
    problem, blocks = analyse_face(one_sided, ALL)
    assert problem.startswith("face in profile or badly fitted") and blocks is None
    assert face_problem(one_sided) == problem and face_problem(obs) == ""
    flags = obs.landmarks[:, 0] > 160  # the landmarks under the noise, flagged as a fit flags them
    flagged = FaceObservation.from_arrays(half, obs.landmarks, None, occluded=flags)
    why, blocks = analyse_face(flagged, ALL, QualityLimits(max_covered=1.0))
    assert why.startswith("face covered") and "mirror image" in why and blocks is None
    bad = FaceObservation.from_arrays(obs.image, obs.landmarks[:51], None)
    assert face_problem(bad).startswith("unusable landmarks")
    with pytest.raises(FaceFeatureError, match=r"68 iBUG landmarks"):
        analyse_face(bad, ALL, check=False)


def test_observe_stacks_the_blocks_and_zeroes_refused_faces() -> None:
    good, other = observation(), observation(70.0, 5.0, seed=1)
    none = FaceObservation.from_arrays(good.image, None, None, True, "no face")
    observed = observe([good, none, other], ALL)
    assert observed.problems == ["", "no face", ""]
    assert observed.ok.tolist() == [True, False, True]
    X = observed.vectors(("hog", "shape"))
    assert X.shape == (3, 1972) and np.all(X[1] == 0)
    assert observed.dims(("shape", "appearance")) == {"shape": 136, "appearance": 5}
    np.testing.assert_array_equal(X[0], feature_vector(analyse_face(good, FeatureConfig())[1],
                                                       FeatureConfig()))
