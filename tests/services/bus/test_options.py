"""services.bus.options: one dataclass gives the parser, the checked values and the argv."""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import pytest

from services.bus.options import (
    OptionError,
    Options,
    add_options,
    in_range,
    option,
    options_argv,
    options_from,
    options_of_mapping,
)


@dataclass(frozen=True)
class Demo(Options):
    rate: float = option(2.0, "a rate", check=in_range(0, 10))
    name: str | None = option(None, "a name", env="DEMO_NAME")
    mode: str = option("fast", "a mode", choices=("fast", "slow"))
    flag: bool = option(True, "a flag")
    items: tuple[str, ...] = option((), "items", env="DEMO_ITEMS")
    count: int = option(1, "a count", check=in_range(1))


def parse(argv: list[str]) -> Demo:
    parser = argparse.ArgumentParser()
    add_options(parser, Demo)
    return options_from(Demo, parser.parse_args(argv))


def test_defaults_come_from_the_dataclass() -> None:
    assert parse([]) == Demo()


def test_command_line_values_and_their_argv_round_trip() -> None:
    opts = parse(["--rate", "3.5", "--name", "x", "--mode", "slow", "--no-flag", "--items", "a",
                  "--items", "b", "--count", "4"])
    assert opts == Demo(3.5, "x", "slow", False, ("a", "b"), 4)
    assert parse(options_argv(opts)) == opts
    assert options_argv(Demo()) == []


def test_environment_fills_what_the_command_line_leaves(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("DEMO_NAME", "from-env")
    monkeypatch.setenv("DEMO_ITEMS", "a, b,,c")
    assert parse([]).name == "from-env" and parse([]).items == ("a", "b", "c")
    assert parse(["--name", "given"]).name == "given"


@pytest.mark.parametrize(("argv", "message"), [
    (["--rate", "11"], "--rate 11.0: must be a number from 0 to 10"),
    (["--rate", "nan"], "--rate nan: must be a number"),
    (["--count", "0"], "--count 0: must be a number from 1"),
])
def test_values_out_of_range_name_the_option(argv: list[str], message: str) -> None:
    with pytest.raises(OptionError) as err:
        parse(argv)
    assert str(err.value).startswith(message)


def test_choices_are_checked_on_construction_too() -> None:
    with pytest.raises(OptionError, match="--mode 'medium': choose one of fast, slow"):
        Demo(mode="medium")
    with pytest.raises(OptionError, match="--rate"):
        Demo().replace(rate=-1.0)


def test_a_mapping_of_field_names_gives_the_options() -> None:
    opts = options_of_mapping(Demo, {"rate": 4, "items": ["x"], "flag": False}, "file [demo]")
    assert opts == Demo(rate=4.0, items=("x",), flag=False)
    with pytest.raises(OptionError, match=r"file \[demo\]: unknown option 'speed'"):
        options_of_mapping(Demo, {"speed": 1}, "file [demo]")
    with pytest.raises(OptionError, match="count = 'two' is not a int"):
        options_of_mapping(Demo, {"count": "two"}, "file")
    with pytest.raises(OptionError, match="file: --rate 99.0"):
        options_of_mapping(Demo, {"rate": 99}, "file")


def test_only_the_named_options_are_read_and_a_base_fills_the_rest() -> None:
    parser = argparse.ArgumentParser()
    add_options(parser, Demo, only=("rate",))
    args = parser.parse_args(["--rate", "5"])
    assert not hasattr(args, "name")
    base = Demo(name="base", count=3)
    assert options_from(Demo, args, only=("rate",), base=base) == Demo(5.0, "base", count=3)


@dataclass(frozen=True)
class Outputs(Options):
    path: str | None = option(None, "a file", metavar="PATH", aliases=("--save",))
    url: str | None = option(None, "a URL", metavar="URL", const="http://default",
                             check=lambda v: "" if v is None or "://" in v else "not a URL")


def parse_outputs(argv: list[str], flags: dict[str, tuple[str, ...]] | None = None) -> Outputs:
    parser = argparse.ArgumentParser()
    add_options(parser, Outputs, flags=flags)
    return options_from(Outputs, parser.parse_args(argv), flags=flags)


def test_an_alias_gives_the_same_option_and_the_argv_uses_the_own_flag() -> None:
    assert parse_outputs(["--save", "a.rrd"]) == parse_outputs(["--path", "a.rrd"])
    assert options_argv(parse_outputs(["--save", "a.rrd"])) == ["--path", "a.rrd"]


def test_an_option_with_a_const_takes_an_optional_value() -> None:
    assert parse_outputs([]).url is None
    assert parse_outputs(["--url"]).url == "http://default"
    assert parse_outputs(["--url", "--path", "x"]) == Outputs("x", "http://default")
    assert parse_outputs(["--url", "ftp://here"]).url == "ftp://here"
    assert options_argv(parse_outputs(["--url"])) == ["--url", "http://default"]
    parser = argparse.ArgumentParser()
    add_options(parser, Outputs)
    assert "(without a value: http://default)" in parser.format_help().replace("\n", " ")


def test_other_flags_replace_an_options_own_and_name_it_in_errors() -> None:
    flags = {"url": ("--connect",)}
    assert parse_outputs(["--connect"], flags).url == "http://default"
    assert parse_outputs(["--connect", "a://b", "--save", "p"], flags) == Outputs("p", "a://b")
    with pytest.raises(SystemExit):
        parse_outputs(["--url", "a://b"], flags)
    with pytest.raises(OptionError) as err:
        parse_outputs(["--connect", "nowhere"], flags)
    assert str(err.value) == "--connect 'nowhere': not a URL" and err.value.option == "url"
    with pytest.raises(OptionError, match="^--url 'nowhere': not a URL$"):
        parse_outputs(["--url", "nowhere"])


def test_errors_name_the_field_at_fault() -> None:
    with pytest.raises(OptionError) as err:
        Demo(count=0)
    assert err.value.option == "count"
    assert OptionError("any").option is None
