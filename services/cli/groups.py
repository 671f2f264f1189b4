"""Command groups that several command modules add to."""

from __future__ import annotations

import argparse

from services.cli.commands import add_command


def eval_group(sub: argparse._SubParsersAction) -> argparse._SubParsersAction:
    """The sub-commands of ``aamtrack eval``, creating ``eval`` if no module has yet."""
    parser = sub.choices.get("eval")
    if parser is None:
        parser = add_command(sub, "eval")
        return parser.add_subparsers(dest="eval_command", required=True, metavar="WHAT")
    for action in parser._actions:  # argparse keeps its sub-command sets only here
        if isinstance(action, argparse._SubParsersAction):
            return action
    return parser.add_subparsers(dest="eval_command", required=True, metavar="WHAT")
