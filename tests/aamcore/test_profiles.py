"""aamcore.profiles: the default and the thesis pipelines, named."""

from __future__ import annotations

import pytest

from aamcore import defaults
from aamcore.fitting.config import FITTER
from aamcore.profiles import PROFILES, Profile, profile_named


def test_the_thesis_profile_is_the_thesis_pipeline() -> None:
    thesis = profile_named("thesis")
    assert (thesis.fitter.algorithm, thesis.fitter.failure_test) == ("fixed-jacobian", "eq7.2")
    assert thesis.pose_estimator == "posit" and thesis.expression == "thesis"
    assert thesis.update_method == "jacobian" and thesis.fitter.appearance
    default = profile_named("default")
    assert default.fitter == FITTER and default.pose_estimator == defaults.POSE_ESTIMATOR
    assert default.expression == "deployed" and set(PROFILES) == {"default", "thesis"}


def test_unknown_names_are_refused() -> None:
    with pytest.raises(ValueError, match="unknown profile 'nope'"):
        profile_named("nope")
    with pytest.raises(ValueError, match="unknown pose estimator"):
        Profile("x", "", FITTER, pose_estimator="solvepnp")
    with pytest.raises(ValueError, match="unknown expression features"):
        Profile("x", "", FITTER, expression="hog-only")
