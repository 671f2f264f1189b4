"""The options of ``aamtrack run``: the options tree, a part per stage handed to the services
of its stage, grouped by stage in the help, checked before start."""

from __future__ import annotations

import argparse

import pytest

from aamcore.operators.options import PIPELINE, STAGES
from aamcore.profiles import profile_named
from services.bus.options import OptionError
from services.stack.options import add_run_options, parse_run_args, pipeline


def test_default_run_starts_every_stage_and_smooths() -> None:
    opts = parse_run_args(["--video", "clip.mp4"])
    assert list(opts.services) == ["source", "detector", "fitter", "pose", "expression", "ar"]
    assert opts.services["fitter"].fit.landmark_smoothing and opts.services["pose"].pose.smoothing
    assert pipeline(opts) == PIPELINE


def test_no_smooth_reaches_every_stage() -> None:
    opts = parse_run_args(["--video", "clip.mp4", "--no-smooth"])
    assert not opts.services["fitter"].fit.landmark_smoothing
    assert not opts.services["pose"].pose.smoothing
    assert opts.services["expression"].expression.hold == 0
    assert parse_run_args(["--video", "clip.mp4"]).services["expression"].expression.hold > 0
    assert pipeline(opts) == PIPELINE.smoothed(False)


def test_each_service_takes_the_parts_of_its_stage() -> None:
    opts = parse_run_args(["--video", "clip.mp4", "--fov", "70", "--scale-factor", "1.2",
                           "--expression-average", "3", "--all-poses", "--model-limit", "5"])
    assert opts.services["pose"].pose.fov == 70.0
    assert opts.services["detector"].detect.scale_factor == 1.2
    assert opts.services["expression"].expression.average == 3
    assert opts.services["ar"].overlay.all_poses and opts.services["fitter"].model.limit == 5
    assert "expression" not in parse_run_args(["--video", "x.mp4", "--no-expression"]).services


def test_an_output_starts_the_rerun_service() -> None:
    assert "rerun" in parse_run_args(["--video", "clip.mp4", "--rrd", "out.rrd"]).services
    assert "ar" not in parse_run_args(["--video", "clip.mp4", "--no-ar"]).services


def test_options_are_checked_with_their_ranges_and_named_with_their_stage() -> None:
    with pytest.raises(OptionError, match=r"^--fov 0.0: must be a number from 1 to 179 \(pose "
                                          r"stage\)$"):
        parse_run_args(["--video", "clip.mp4", "--fov", "0"])
    with pytest.raises(OptionError, match=r"^--calibration 'c.yaml': give --fov or "
                                          r"--calibration, not both \(pose stage\)$"):
        parse_run_args(["--video", "clip.mp4", "--fov", "70", "--calibration", "c.yaml"])


def test_the_help_shows_the_common_options_first_then_each_stage() -> None:
    parser = argparse.ArgumentParser(prog="aamtrack run")
    add_run_options(parser)
    text = parser.format_help()
    titles = [line[:-1] for line in text.splitlines() if line.endswith("options:")]
    assert titles[:2] == ["options", "common options"]
    assert titles[2:] == [f"{stage} options" for stage in STAGES]
    common = text[text.index("common options:"):text.index("model options:")]
    assert all(flag in common for flag in ("--video", "--profile", "--max-faces", "--rrd"))


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


def test_a_profile_sets_each_stage_and_given_options_override_it() -> None:
    thesis = parse_run_args(["--video", "x.mp4", "--profile", "thesis"])
    assert pipeline(thesis) == profile_named("thesis").options
    fitting, pose = thesis.services["fitter"].fit.fitting, thesis.services["pose"].pose
    assert (fitting.algorithm, fitting.failure_test, pose.estimator) == (
        "fixed-jacobian", "eq7.2", "posit")
    assert thesis.launch.profile == "thesis" and fitting.appearance
    mixed = parse_run_args(["--video", "x.mp4", "--profile", "thesis", "--estimator", "contour",
                            "--no-occlusion", "--refine", "2"])
    assert mixed.services["pose"].pose.estimator == "contour"
    fitting = mixed.services["fitter"].fit.fitting
    assert fitting.algorithm == "fixed-jacobian"
    assert fitting.occlusion is False and fitting.refine == 2


def test_every_stage_keeps_faces_by_the_fit_stages_rule() -> None:
    opts = parse_run_args(["--video", "x.mp4", "--max-faces", "3", "--new-faces-hidden-frames",
                           "30"])
    assert opts.services["fitter"].fit.new_faces.hidden_frames == 30
    assert opts.services["pose"].new_faces.hidden_frames == 30
    assert opts.services["expression"].new_faces.hidden_frames == 30
