"""aamcore.expression.quality: the gate's checks on the landmarks, each with its reason."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.expression.crop import FaceObservation
from aamcore.expression.quality import (
    landmark_problem,
    reason_key,
    shape_deviation,
    symmetry_problem,
)
from aamcore.expression.spec import QualityLimits
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
