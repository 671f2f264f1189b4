"""The ``aamtrack`` commands: their names, one-line help and the modules that add them.

``aamtrack --help`` lists them from here without importing a command module, and
``aamtrack CMD ...`` imports only the modules of ``CMD`` (``tests/services/cli/test_help.py``
checks that help imports neither numpy, OpenCV, scikit-learn nor the algorithms).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass


@dataclass(frozen=True)
class Command:
    """One top-level command: ``help`` as ``aamtrack --help`` lists it, the ``modules``
    whose ``register(subparsers)`` adds it (several for a group such as ``eval``)."""

    help: str
    modules: tuple[str, ...]
    aliases: tuple[str, ...] = ()


_CLI = "services.cli."
COMMANDS: dict[str, Command] = {
    "track": Command("track a video without the bus and write its per-frame results, "
                     "an annotated video", (_CLI + "export_cmd",)),
    "run": Command("run the tracking stack on a video, camera or stream", (_CLI + "run_cmd",)),
    "export": Command("a recording's per-frame results as CSV, JSON Lines, a Rerun "
                      "recording or an annotated video", (_CLI + "export_cmd",)),
    "model": Command("prepare the default models, inspect one", (_CLI + "model_cmd",),
                     ("models",)),
    "train": Command("train an AAM (and with --fit everything fitting needs) from annotated "
                     "faces", (_CLI + "train_cmd",)),
    "fit": Command("fit a model to images, writing landmarks as JSON", (_CLI + "fit_cmd",)),
    "eval": Command("evaluate accuracy and speed against ground truth",
                    (_CLI + "fit_cmd", _CLI + "pose_cmd", _CLI + "expression_cmd")),
    "synth": Command("render a head under known poses: video + per-frame JSON",
                     (_CLI + "pose_cmd",)),
    "echo": Command("print the messages on a key expression", (_CLI + "bus_cmd",)),
    "record": Command("record a stream's result messages to a file", (_CLI + "bus_cmd",)),
    "service": Command("run one service of the stack alone", (_CLI + "run_cmd",)),
    "router": Command("run a Zenoh router (where zenohd is not installed)",
                      (_CLI + "router_cmd",)),
    "keys": Command("write a new keys file for a deployment over several hosts",
                    (_CLI + "router_cmd",)),
}
"""Every command, in the order ``aamtrack --help`` lists them."""


def canonical(name: str) -> str | None:
    """The command ``name`` stands for (itself or the command it is an alias of), or None."""
    if name in COMMANDS:
        return name
    return next((c for c, command in COMMANDS.items() if name in command.aliases), None)


def add_command(sub: argparse._SubParsersAction, name: str, **kwargs: object
                ) -> argparse.ArgumentParser:
    """Add the parser of command ``name`` with its help and aliases from :data:`COMMANDS`."""
    command = COMMANDS[name]
    return sub.add_parser(name, help=command.help, aliases=list(command.aliases), **kwargs)
