"""The options of ``aamtrack run``: derived from the services', checked before start."""

from __future__ import annotations

import pytest

from aamcore.tracker_config import TRACKER
from services.bus.options import OptionError
from services.stack.options import parse_run_args


def test_default_run_starts_every_stage_and_smooths() -> None:
    opts = parse_run_args(["--video", "clip.mp4"])
    assert list(opts.services) == ["source", "detector", "fitter", "pose", "expression", "ar"]
    assert opts.services["fitter"].tracking.smoothing and opts.services["pose"].smooth


def test_no_smooth_reaches_fitter_and_pose() -> None:
    opts = parse_run_args(["--video", "clip.mp4", "--no-smooth"])
    assert not opts.services["fitter"].tracking.smoothing
    assert not opts.services["pose"].smooth
    assert opts.services["expression"].hold == 0
    assert parse_run_args(["--video", "clip.mp4"]).services["expression"].hold > 0


def test_an_output_starts_the_rerun_service() -> None:
    assert "rerun" in parse_run_args(["--video", "clip.mp4", "--rrd", "out.rrd"]).services
    assert "ar" not in parse_run_args(["--video", "clip.mp4", "--no-ar"]).services


def test_service_options_are_checked_with_their_ranges() -> None:
    with pytest.raises(OptionError, match="--fov"):
        parse_run_args(["--video", "clip.mp4", "--fov", "0"])


def test_a_run_needs_an_input() -> None:
    with pytest.raises(OptionError, match="--video"):
        parse_run_args([])


def test_set_passes_an_argument_to_one_service() -> None:
    opts = parse_run_args(["--video", "clip.mp4", "--set", "fitter:--detect-timeout=2"])
    assert opts.extra == {"fitter": ["--detect-timeout=2"]}
    with pytest.raises(OptionError, match="SERVICE:ARG"):
        parse_run_args(["--video", "clip.mp4", "--set", "nobody:--x"])


def test_fast_pacing_keeps_every_fit_for_pose_and_expression() -> None:
    from services.expression.options import ExpressionOptions
    from services.pose.options import PoseOptions
    from services.stack.options import FAST_CAPACITY

    fast = parse_run_args(["--video", "clip.mp4", "--pace", "fast"]).services
    assert fast["pose"].capacity == fast["expression"].capacity == FAST_CAPACITY
    live = parse_run_args(["--video", "clip.mp4"]).services
    # Live: the services' own capacities (a burst is worked off, old fits go).
    assert live["pose"].capacity == PoseOptions().capacity < FAST_CAPACITY
    assert live["expression"].capacity == ExpressionOptions().capacity < FAST_CAPACITY
    chosen = parse_run_args(["--video", "clip.mp4", "--pace", "fast"])
    assert chosen.services["fitter"].algorithm == "local-binary"
    fitting = chosen.services["fitter"].tracking.fitting
    assert fitting.failure_test == "auto" and fitting.appearance


def test_a_profile_sets_each_stage_and_given_options_override_it() -> None:
    thesis = parse_run_args(["--video", "x.mp4", "--profile", "thesis"])
    fitter, pose = thesis.services["fitter"], thesis.services["pose"]
    fitting = fitter.tracking.fitting
    assert (fitting.algorithm, fitting.failure_test, pose.estimator) == (
        "fixed-jacobian", "eq7.2", "posit")
    assert thesis.launch.profile == "thesis" and fitting.appearance
    mixed = parse_run_args(["--video", "x.mp4", "--profile", "thesis", "--estimator", "contour",
                            "--no-occlusion", "--refine", "2"])
    assert mixed.services["pose"].estimator == "contour"
    fitting = mixed.services["fitter"].tracking.fitting
    assert fitting.algorithm == "fixed-jacobian"
    assert fitting.occlusion is False and fitting.refine == 2
    default = parse_run_args(["--video", "x.mp4"])
    assert default.services["fitter"].config() == TRACKER
