"""aamcore.expression.quality: the gate's checks on the landmarks, each with its reason."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from aamcore.expression.analysis import analyse_face
from aamcore.expression.crop import FaceObservation
from aamcore.expression.quality import (
    blur_problem,
    landmark_problem,
    reason_key,
    shape_deviation,
    sharpness,
    symmetry_problem,
)
from aamcore.expression.spec import FeatureConfig, QualityLimits
from tests.aamcore.expression.synthetic_faces import observation, place, unit_face


def _points(change: str) -> np.ndarray | None:
    face = unit_face()
    if change == "none":
        return None
    if change == "small":
        return place(face, 10.0, 0.0, (160.0, 110.0))
    if change == "outside":
        return place(face, 60.0, 0.0, (300.0, 110.0))
    if change == "far outside":
        return place(face, 60.0, 0.0, (5000.0, -3000.0))
    if change == "rolled":
        return place(face, 60.0, 60.0, (160.0, 110.0))
    if change == "profile":
        face[27:36, 0] += 0.45  # the nose far to one side: turned about 40 degrees
    elif change == "scrambled":
        face[48:68] = face[48:68][::-1] + [0.0, -1.2]
    elif change == "nan":
        face[5] = np.nan
    return place(face, 60.0, 0.0, (160.0, 110.0))


@pytest.mark.parametrize(
    ("change", "key"),
    [
        ("none", "no face"),
        ("nan", "unusable landmarks"),
        ("small", "face too small"),
        ("outside", "face outside the frame"),
        ("far outside", "face outside the frame"),
        ("rolled", "head rolled"),
        ("profile", "face in profile"),
        ("scrambled", "implausible landmarks"),
    ],
)
def test_the_gate_says_why_a_face_is_not_classified(change: str, key: str) -> None:
    image = observation().image
    obs = FaceObservation.from_arrays(image, _points(change), None, True, "no face")
    why = landmark_problem(obs, QualityLimits(), unit_face())
    assert reason_key(why) == key, why


def test_a_good_face_passes_and_a_failed_fit_is_no_reason() -> None:
    obs = observation()
    assert landmark_problem(obs, template=unit_face()) == ""
    failed = FaceObservation.from_arrays(obs.image, obs.landmarks, None, True, "appearance")
    assert landmark_problem(failed) == ""
    assert shape_deviation(obs.landmarks, unit_face()) == pytest.approx(0.0, abs=1e-6)


def test_reasons_name_the_fitters_verdict_and_the_symmetry() -> None:
    image = observation().image
    assert landmark_problem(FaceObservation.from_arrays(image, None, None, True, "")) == "no face"
    lost = FaceObservation.from_arrays(image, None, None, True, "non-finite result")
    assert landmark_problem(lost) == "no face: non-finite result"
    assert symmetry_problem(0.9) == ""
    why = symmetry_problem(0.5)
    assert reason_key(why) == "face in profile or badly fitted" and "0.50" in why
    flags = np.zeros(68, bool)
    flags[48:52] = True  # 4 of the 51 inner landmarks: a hand over a corner of the mouth
    covered = symmetry_problem(0.5, flags=flags)
    assert reason_key(covered) == "face covered" and "8 %" in covered and "0.50" in covered
    assert symmetry_problem(0.9, flags=flags) == ""
    assert reason_key(symmetry_problem(0.5, flags=np.zeros(68, bool))) == (
        "face in profile or badly fitted")
    assert reason_key("no face") == "no face"


def test_a_face_covered_beyond_the_limit_is_refused_with_its_share() -> None:
    good = observation()
    flags = np.zeros(68, bool)
    flags[48:68] = True  # the mouth under a hand: 20 of the 51 inner landmarks
    covered = FaceObservation.from_arrays(good.image, good.landmarks, good.appearance,
                                          occluded=flags)
    assert landmark_problem(covered) == ("face covered: 39 % of the inner landmarks occluded "
                                         "(at most 20 %)")
    assert landmark_problem(covered, QualityLimits(max_covered=0.5)) == ""
    flags[:] = False
    flags[0:17] = True  # the jaw only: the expression's landmarks are visible
    jaw = FaceObservation.from_arrays(good.image, good.landmarks, good.appearance,
                                      occluded=flags)
    assert landmark_problem(jaw) == ""
    # Flags of another length are not the fit's: ignored.
    odd = FaceObservation.from_arrays(good.image, good.landmarks, good.appearance,
                                      occluded=np.ones(5, bool))
    assert odd.occluded is None and landmark_problem(odd) == ""


def test_a_blurred_face_is_refused_and_the_same_face_sharp_or_dim_is_not(jaffe) -> None:
    """Real faces as the stack fits them: sharp, at a third of the exposure and blurred by a
    Gaussian of 3 crop pixels (a sixteenth of the eye distance, where the held-out people's
    expressions were read no better than a coin's toss among the likely classes)."""
    config = FeatureConfig()
    for i in range(0, len(jaffe.labels), 43):
        obs = jaffe.observations[i]
        eyes = obs.landmarks[42:48].mean(axis=0) - obs.landmarks[36:42].mean(axis=0)
        sigma = 3.0 * float(np.hypot(*eyes)) / config.eye_distance
        dim = (obs.image * (1.0 / 3.0)).round().astype(np.uint8)
        blurred = cv2.GaussianBlur(obs.image, (0, 0), sigma)
        for image, refused in ((obs.image, False), (dim, False), (blurred, True)):
            seen = FaceObservation.from_arrays(image, obs.landmarks, obs.appearance)
            why, blocks = analyse_face(seen, config)
            assert (reason_key(why) == "face blurred") == refused, (i, why)
            assert (blocks is None) == refused
            # the training learns from a face refused only as blurred: its blocks, its reason
            learnt, kept = analyse_face(seen, config, learn_blurred=True)
            assert learnt == why and kept is not None
            plain = analyse_face(seen, config, check=False)[1]
            assert plain is not None
            np.testing.assert_array_equal(kept["hog"], plain["hog"])
    limit = QualityLimits().min_sharpness
    assert blur_problem(limit + 5.0) == ""
    assert f"sharpness 40 (at least {limit:g};" in blur_problem(40.0)


def test_sharpness_is_of_the_texture_not_of_its_brightness_or_contrast() -> None:
    obs = observation()
    crop = cv2.equalizeHist(cv2.cvtColor(obs.image, cv2.COLOR_BGR2GRAY)
                            if obs.image.ndim == 3 else obs.image)
    points = obs.landmarks
    value = sharpness(crop, points)
    assert value > 0
    assert sharpness(cv2.GaussianBlur(crop, (0, 0), 2.0), points) < value / 4
    assert sharpness(np.full_like(crop, 128), points) == 0.0
