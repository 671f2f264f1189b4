"""The tracker's one configuration reaches every door: each value of
:class:`~aamcore.tracker_config.TrackerConfig` can be set from the library, ``aamtrack run``,
``aamtrack track``, the service that carries it and the stack file, and a bad value gets one
error naming it, the same from each. A value added to the configuration is checked here
without a line more."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import pytest

from aamcore.settings import ConfigError, Setting
from aamcore.tracker import FaceTracker
from aamcore.tracker_config import TRACKER, TrackerConfig
from services.bus.args import parse_service_args
from services.bus.options import OptionError
from services.cli import main as aamtrack
from services.cli.track_options import add_track_options, track_options
from services.expression.options import ExpressionOptions
from services.fitter.options import ELSEWHERE, FitterOptions
from services.stack.options import parse_run_args, tracker_config
from services.stack.stack_file import read_stack_file

SETTINGS = TrackerConfig.settings()


def other_value(s: Setting) -> object:
    """A valid value of ``s`` other than its default."""
    if s.kind is bool:
        return s.default is not True
    if s.choices is not None:
        return next(c for c in s.choices if c != s.default)
    if s.default is None:
        return 5
    if s.kind is float:
        return 2.5 if math.isinf(s.default) else round(s.default * 0.8 + 0.05, 3)
    return s.default + 1 if s.problem(s.default + 1) == "" else s.default - 1


def flag_args(s: Setting, value: object, flag: str | None = None) -> list[str]:
    flag = flag or s.flag
    if isinstance(value, bool):
        return [flag if value else "--no-" + flag[2:]]
    return [flag, str(value)]


@pytest.mark.parametrize("s", SETTINGS, ids=[s.name for s in SETTINGS])
def test_every_value_reaches_every_door(s: Setting, tmp_path: Path) -> None:
    value = other_value(s)
    assert TRACKER.with_values(**{s.name: value}).values()[s.name] == value  # the library
    run = flag_args(s, value, "--smooth" if s.name == "smoothing" else None)
    assert tracker_config(parse_run_args(["--video", "x.mp4", *run])).values()[s.name] == value
    parser = argparse.ArgumentParser()
    add_track_options(parser)
    assert track_options(parser.parse_args(flag_args(s, value))).tracking.values()[
        s.name] == value
    service, options, key = ("fitter", FitterOptions, s.flag[2:])
    if s.name in ELSEWHERE:  # the expression service's own --hold
        service, options, key = ("expression", ExpressionOptions, "hold")
    given = parse_service_args(service, "", options, flag_args(s, value, "--" + key)).options
    got = given.hold if service == "expression" else given.tracking.values()[s.name]
    assert got == value
    stack = tmp_path / "stack.toml"
    shown = str(value).lower() if isinstance(value, bool) else (
        f'"{value}"' if isinstance(value, str) else repr(value))
    stack.write_text(f"[hosts.here]\nservices = [\"{service}\"]\n\n"
                     f"[services.{service}]\n{key} = {shown}\n")
    opts = read_stack_file(stack).services[service]
    assert (opts.hold if service == "expression" else opts.tracking.values()[s.name]) == value


BAD = [
    ({"max_faces": 65}, "--max-faces 65", "must be a whole number from 1 to 64"),
    ({"refit_every": -1}, "--refit-every -1", "must be a whole number from 0"),
    ({"refit_moving": -1}, "--refit-moving -1", "must be a number from 0"),  # int for float
    ({"appearance": False, "occlusion": True}, "--no-appearance --occlusion",
     "needs the appearance"),
]


@pytest.mark.parametrize(("values", "flags", "problem"), BAD)
def test_a_bad_value_gets_one_error_naming_it_from_each_door(
        values: dict, flags: str, problem: str, tmp_path: Path, single_face: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    name = list(values)[-1]
    flag = "--" + name.replace("_", "-")
    with pytest.raises(ConfigError) as library:
        FaceTracker(**values)  # refused before any model is loaded
    assert library.value.field == name and problem in str(library.value)
    assert str(library.value).startswith(f"{name} ")
    with pytest.raises(OptionError) as run:
        parse_run_args(["--video", "x.mp4", *flags.split()])
    assert str(run.value).startswith(f"{flag} ") and problem in str(run.value)
    code = aamtrack(["track", str(single_face), "--csv", str(tmp_path / "out.csv"),
                     *flags.split()])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith(f"aamtrack track: error: {flag} ")
    assert problem in err[0]
    stack = tmp_path / "stack.toml"
    table = "\n".join(f"{k.replace('_', '-')} = {str(v).lower()}" for k, v in values.items())
    stack.write_text(f"[hosts.here]\nservices = [\"fitter\"]\n\n[services.fitter]\n{table}\n")
    with pytest.raises(OptionError) as file:
        read_stack_file(stack)
    assert f"[services.fitter]: {flag} " in str(file.value)
    assert problem in str(file.value)


def test_an_unknown_value_is_named_with_the_closest_one(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="refit_evry: unknown setting; did you mean "
                                          "refit_every"):
        FaceTracker(refit_evry=2)
    with pytest.raises(SystemExit):
        parse_run_args(["--video", "x.mp4", "--refit-evry", "2"])
    stack = tmp_path / "stack.toml"
    stack.write_text("[hosts.here]\nservices = [\"fitter\"]\n\n[services.fitter]\n"
                     "refit-evry = 2\n")
    with pytest.raises(OptionError, match="unknown option 'refit-evry'; did you mean "
                                          "refit-every"):
        read_stack_file(stack)
