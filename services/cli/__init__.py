"""The ``aamtrack`` command.

Each command group lives in its own module with a ``register(subparsers)``
function that adds its sub-command(s) and sets ``func`` on the parser; this
module only gathers them. To add a command, write a module and list it in
``COMMAND_MODULES``.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys

COMMAND_MODULES: tuple[str, ...] = (
    "services.cli.train_cmd",
    "services.cli.model_cmd",
    "services.cli.fit_cmd",
    "services.cli.pose_cmd",
    "services.cli.expression_cmd",
    "services.cli.run_cmd",
    "services.cli.bus_cmd",
    "services.cli.export_cmd",
    "services.cli.router_cmd",
)


def build_parser() -> argparse.ArgumentParser:
    """Return the parser with every command group registered."""
    parser = argparse.ArgumentParser(
        prog="aamtrack", description="Real-time face tracking with Active Appearance Models."
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="log debug messages")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``aamtrack`` console command; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO,
        format="%(asctime)s %(name)s %(levelname)s %(message)s",
    )
    try:
        return int(args.func(args) or 0)
    except (FileNotFoundError, ValueError) as exc:
        print(f"aamtrack {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"aamtrack {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
