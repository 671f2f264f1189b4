"""The ``aamtrack`` command.

Each command group lives in its own module with a ``register(subparsers)``
function that adds its sub-command(s) and sets ``func`` on the parser;
:data:`services.cli.commands.COMMANDS` lists every command with its help and
modules. ``aamtrack CMD ...`` imports only the modules of ``CMD``, and those
import the algorithms only when a command runs, so that help comes at once. To add
a command, write a module and list it in ``COMMANDS``.
"""

from __future__ import annotations

import os
import signal
import sys

EXIT_INTERRUPTED = 130
"""The exit code of a command stopped by Ctrl-C (128 + SIGINT), as shells give it."""


def _interrupted_early(signum: int, frame: object) -> None:
    os.write(2, b"aamtrack: interrupted\n")
    os._exit(EXIT_INTERRUPTED)


def _first_of_all() -> None:
    """What the ``aamtrack`` command does before any other import: make itself non-dumpable
    (a launcher's keys are made later in this process; no other process of the user may
    read its memory), and end on Ctrl-C with one line while it imports (:func:`main` puts
    the usual handling in place)."""
    signal.signal(signal.SIGINT, _interrupted_early)
    import contextlib
    import ctypes

    # Where it fails, the launcher says so, and stops, before it makes any key.
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None).prctl(4, 0, 0, 0, 0)  # PR_SET_DUMPABLE 0


if os.path.basename(sys.argv[0]) == "aamtrack":  # the console command, not an import
    _first_of_all()

import argparse  # noqa: E402
import importlib  # noqa: E402
from collections.abc import Sequence  # noqa: E402

from services.cli.commands import COMMANDS, canonical  # noqa: E402


def _parser(modules: Sequence[str]) -> tuple[argparse.ArgumentParser, argparse._SubParsersAction]:
    parser = argparse.ArgumentParser(
        prog="aamtrack", description="Real-time face tracking with Active Appearance Models."
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="log debug messages")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in dict.fromkeys(modules):
        importlib.import_module(name).register(sub)
    return parser, sub


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser of every command; with ``command``, of that one only (the others listed
    by name and help, their modules not imported)."""
    if command is None:
        return _parser([m for c in COMMANDS.values() for m in c.modules])[0]
    chosen = canonical(command)
    parser, sub = _parser(COMMANDS[chosen].modules if chosen else ())
    for name, listed in COMMANDS.items():
        if name not in sub.choices:
            sub.add_parser(name, help=listed.help, aliases=list(listed.aliases))
    return parser


def chosen_parser(parser: argparse.ArgumentParser, args: argparse.Namespace
                  ) -> argparse.ArgumentParser:
    """The parser of the (sub-)command ``args`` chose: ``aamtrack eval pose``'s for
    ``aamtrack eval pose ...``, the top-level one when none was chosen."""
    for action in parser._actions:  # argparse keeps its sub-command sets only here
        if isinstance(action, argparse._SubParsersAction):
            name = getattr(args, action.dest, None)
            if name in action.choices:
                return chosen_parser(action.choices[name], args)
    return parser


def parse(parser: argparse.ArgumentParser, argv: Sequence[str]) -> argparse.Namespace:
    """``parser.parse_args(argv)``, but an argument no one knows is refused with the usage of
    the sub-command it was given to (exit 2), not the top-level one argparse prints."""
    args, unknown = parser.parse_known_args(argv)
    if unknown:
        chosen_parser(parser, args).error(f"unrecognized arguments: {' '.join(unknown)}")
    return args


def command_in(argv: Sequence[str]) -> str:
    """The command word of ``argv`` (its first word that is not an option), or ``""``."""
    return next((word for word in argv if not word.startswith("-")), "")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``aamtrack`` console command; returns the exit code.

    Ctrl-C at any moment, importing included, ends it with one line and exit code 130.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    command = command_in(argv)
    # FFmpeg's own lines (a file that is no video: "moov atom not found") would come before
    # aamtrack's message that says the same; set it to 16 or more to see them.
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")
    try:
        if signal.getsignal(signal.SIGINT) is _interrupted_early:
            signal.signal(signal.SIGINT, signal.default_int_handler)
        return _main(argv, command)
    except KeyboardInterrupt:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C while it stops
        print(f"aamtrack{' ' + command if command else ''}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


def _main(argv: list[str], command: str) -> int:
    import logging

    args = parse(build_parser(command), argv)
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO,
        format="%(asctime)s %(name)s %(levelname)s %(message)s",
    )
    try:
        return int(args.func(args) or 0)
    except (FileNotFoundError, ValueError) as exc:
        print(f"aamtrack {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
