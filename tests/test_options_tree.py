"""The options tree reaches every door: each value of
:class:`~aamcore.operators.options.PipelineOptions` can be set from the library,
``aamtrack run``, ``aamtrack track``, the service of its stage and the stack file, and a bad
value gets one error naming it and its stage, the same from each. A value added to a
stage's part is checked here without a line more."""

from __future__ import annotations

import argparse
import dataclasses
import math
from pathlib import Path

import pytest

from aamcore.operators.options import PIPELINE
from aamcore.settings import ConfigError, Setting
from aamcore.tracker import FaceTracker
from services.bus.args import parse_service_args
from services.bus.options import OptionError
from services.cli import main as aamtrack
from services.cli.track_options import add_track_options, track_options
from services.stack.options import parse_run_args, pipeline
from services.stack.registry import SERVICES
from services.stack.stack_file import read_stack_file

SETTINGS = PIPELINE.settings()


def other_value(s: Setting) -> object:
    """A valid value of ``s`` other than its default."""
    if s.kind is bool:
        return s.default is not True
    if s.choices is not None:
        return next(c for c in s.choices if c != s.default)
    if s.default is None:
        return 5 if s.kind is int else "x.yaml" if s.name == "pose_calibration" else "x.npz"
    if s.kind is float:
        if math.isinf(s.default):
            return 2.5
        tried = (round(s.default * 0.8 + 0.05, 3), round(s.default * 1.1, 3))
    else:
        tried = (s.default + 1, s.default - 1)
    return next(v for v in tried if s.problem(v) == "")


def flag_args(s: Setting, value: object) -> list[str]:
    if isinstance(value, bool):
        return [s.flag if value else "--no-" + s.flag[2:]]
    return [s.flag, str(value)]


def service_of(stage: str) -> str:
    """The service that runs ``stage`` (whose options hold its part)."""
    return next(name for name, info in SERVICES.items()
                if any(f.name == stage for f in dataclasses.fields(info.options)))


@pytest.mark.parametrize("s", SETTINGS, ids=[s.name for s in SETTINGS])
def test_every_value_reaches_every_door(s: Setting, tmp_path: Path) -> None:
    value = other_value(s)
    assert PIPELINE.with_values(**{s.name: value}).values()[s.name] == value  # the library
    assert pipeline(parse_run_args(["--video", "x.mp4", *flag_args(s, value)])).values()[
        s.name] == value
    parser = argparse.ArgumentParser()
    add_track_options(parser)
    assert track_options(parser.parse_args(flag_args(s, value)))[1].values()[s.name] == value
    service = service_of(s.path[0])
    given = parse_service_args(service, "", SERVICES[service].options, flag_args(s, value))
    assert given.options.values()[s.name] == value
    stack = tmp_path / "stack.toml"
    shown = str(value).lower() if isinstance(value, bool) else (
        f'"{value}"' if isinstance(value, str) else repr(value))
    stack.write_text(f"[hosts.here]\nservices = [\"{service}\"]\n\n"
                     f"[services.{service}]\n{s.flag[2:]} = {shown}\n")
    assert read_stack_file(stack).services[service].values()[s.name] == value


BAD = [
    ({"max_faces": 65}, "--max-faces 65", "must be a whole number from 1 to 64", "fit"),
    ({"refit_every": -1}, "--refit-every -1", "must be a whole number from 0", "fit"),
    ({"refit_moving": -1}, "--refit-moving -1", "must be a number from 0", "fit"),  # an int
    ({"appearance": False, "occlusion": True}, "--no-appearance --occlusion",
     "needs the appearance", "fit"),
    ({"pose_fov": 200.0}, "--fov 200", "must be a number from 1 to 179", "pose"),
    ({"expression_hold": -2}, "--expression-hold -2", "must be a whole number from 0",
     "expression"),
]


@pytest.mark.parametrize(("values", "flags", "problem", "stage"), BAD)
def test_a_bad_value_gets_one_error_naming_it_and_its_stage_from_each_door(
        values: dict, flags: str, problem: str, stage: str, tmp_path: Path, single_face: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    name = list(values)[-1]
    flag = PIPELINE.setting(name).flag
    where = f"({stage} stage)"
    with pytest.raises(ConfigError) as library:
        FaceTracker(**values)  # refused before any model is loaded
    assert library.value.field == name and library.value.stage == stage
    assert str(library.value).startswith(f"{name} ") and problem in str(library.value)
    assert str(library.value).endswith(where)
    with pytest.raises(OptionError) as run:
        parse_run_args(["--video", "x.mp4", *flags.split()])
    assert str(run.value).startswith(f"{flag} ") and problem in str(run.value)
    assert str(run.value).endswith(where)
    code = aamtrack(["track", str(single_face), "--csv", str(tmp_path / "out.csv"),
                     *flags.split()])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith(f"aamtrack track: error: {flag} ")
    assert problem in err[0] and err[0].endswith(where)
    service = service_of(PIPELINE.setting(name).path[0])
    stack = tmp_path / "stack.toml"
    table = "\n".join(f"{PIPELINE.setting(k).flag[2:]} = {str(v).lower()}"
                      for k, v in values.items())
    stack.write_text(f"[hosts.here]\nservices = [\"{service}\"]\n\n[services.{service}]\n"
                     f"{table}\n")
    with pytest.raises(OptionError) as file:
        read_stack_file(stack)
    assert f"[services.{service}]: {flag} " in str(file.value)
    assert problem in str(file.value) and str(file.value).endswith(where)


def test_an_unknown_value_is_named_with_the_closest_one(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"refit_evry: unknown setting; did you mean "
                                          r"refit_every \(fit stage\)"):
        FaceTracker(refit_evry=2)
    with pytest.raises(SystemExit):
        parse_run_args(["--video", "x.mp4", "--refit-evry", "2"])
    stack = tmp_path / "stack.toml"
    stack.write_text("[hosts.here]\nservices = [\"fitter\"]\n\n[services.fitter]\n"
                     "refit-evry = 2\n")
    with pytest.raises(OptionError, match="unknown option 'refit-evry'; did you mean "
                                          "refit-every"):
        read_stack_file(stack)


def test_every_default_is_a_value_its_setting_accepts() -> None:
    # a default is not checked on construction (nothing to load for --help): here, once
    from services.stack.options import LaunchOptions

    every = [*SETTINGS, *LaunchOptions.settings()]
    every += [s for info in SERVICES.values() for s in info.options.settings()]
    assert [s.name for s in every if s.problem(s.default)] == []
