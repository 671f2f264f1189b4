"""The options of every ``aamtrack`` command: each argument has a help line, an argument no
one knows gets the usage of the command it was given to (exit 2), and ``run`` has every
stage switch of the library."""

from __future__ import annotations

import argparse
from collections.abc import Iterator

import pytest

from aamcore.operators.options import PIPELINE
from services.cli import build_parser, main


def commands(parser: argparse.ArgumentParser, path: tuple[str, ...] = ()
             ) -> Iterator[tuple[tuple[str, ...], argparse.ArgumentParser]]:
    """Every (sub-)command's words and parser, aliases once."""
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            seen: set[int] = set()
            for name, sub in action.choices.items():
                if id(sub) not in seen:
                    seen.add(id(sub))
                    yield from commands(sub, (*path, name))


COMMANDS = list(commands(build_parser()))
LEAVES = [(path, p) for path, p in COMMANDS
          if path and not any(isinstance(a, argparse._SubParsersAction) for a in p._actions)]


def arguments(parser: argparse.ArgumentParser) -> Iterator[argparse.Action]:
    """Every argument of ``parser`` as its help lists it: options, positionals, and each
    sub-command of a set of them."""
    for a in parser._actions:
        if isinstance(a, argparse._SubParsersAction):
            yield from a._choices_actions
        elif not isinstance(a, argparse._HelpAction):
            yield a


def test_every_argument_of_every_command_has_a_help_line() -> None:
    missing = [f"aamtrack {' '.join(path)} {'/'.join(a.option_strings) or a.dest}"
               for path, parser in COMMANDS for a in arguments(parser)
               if not (a.help or "").strip()]
    assert not missing, missing
    assert sum(1 for _, parser in COMMANDS for _ in arguments(parser)) > 200


def needed(parser: argparse.ArgumentParser) -> list[str]:
    """Arguments that satisfy ``parser``'s positionals and required options."""
    argv: list[str] = []
    for a in parser._actions:
        value = str(a.choices[0]) if isinstance(a.choices, list | tuple) else "1"
        if not a.option_strings:
            argv += [] if a.nargs == argparse.REMAINDER else [value]
        elif a.required:
            argv += [a.option_strings[0], value]
    return argv


@pytest.mark.parametrize("path,parser", LEAVES, ids=[" ".join(p) for p, _ in LEAVES])
def test_an_unknown_option_gets_its_commands_usage(
    path: tuple[str, ...], parser: argparse.ArgumentParser, capfd: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_:
        main([*path, *needed(parser), "--no-such-option"])
    assert exit_.value.code == 2
    err = capfd.readouterr().err.rstrip().splitlines()
    words = " ".join(path)  # ``service NAME`` hands the rest to the service's own parser
    assert err[0].startswith(f"usage: aamtrack {words} ") and len(err) > 1
    assert err[-1].startswith(f"aamtrack {words}")
    assert err[-1].endswith(": error: unrecognized arguments: --no-such-option")


def test_run_has_every_stage_switch_of_the_library() -> None:
    """Each on/off value of the pipeline (a stage's part or a step of it) both ways, and the
    expression stage off as ``FaceTracker(classifier=False)`` turns it off."""
    run = dict(COMMANDS)[("run",)]
    flags = {flag for a in run._actions for flag in a.option_strings}
    switches = [s for s in PIPELINE.settings() if s.kind is bool]
    assert switches
    for s in switches:
        assert {s.flag, "--no-" + s.flag[2:]} <= flags, s.name
    assert {"--expression", "--no-expression", "--ar", "--no-ar"} <= flags
