"""aamcore.profiles: the default and the thesis pipelines, named presets of the options tree."""

from __future__ import annotations

import pytest

from aamcore.operators.options import PIPELINE
from aamcore.profiles import PROFILES, profile_named


def test_the_thesis_profile_is_the_thesis_pipeline() -> None:
    thesis = profile_named("thesis").options
    fitting = thesis.fit.fitting
    assert (fitting.algorithm, fitting.failure_test) == ("fixed-jacobian", "eq7.2")
    assert thesis.pose.estimator == "posit" and thesis.expression.features == "thesis"
    assert thesis.model.update == "jacobian" and fitting.appearance
    changed = {k for k, v in thesis.values().items() if PIPELINE.values()[k] != v}
    assert changed == {"algorithm", "failure_test", "pose_estimator", "expression_features"}
    assert profile_named("default").options == PIPELINE
    assert set(PROFILES) == {"default", "thesis"}


def test_unknown_names_are_refused() -> None:
    with pytest.raises(ValueError, match="unknown profile 'nope'"):
        profile_named("nope")
