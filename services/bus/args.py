"""A service's command line: its bus options, its own options and ``--verbose``."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from services.bus.connection import BusOptions
from services.bus.options import OptionError, Options, add_options, options_argv, options_from


@dataclass(frozen=True)
class ServiceArgs:
    """The parsed command line of a service."""

    bus: BusOptions
    options: Any
    verbose: bool = False


def service_parser(name: str, description: str, options: type[Options]) -> argparse.ArgumentParser:
    """The parser of service ``name``: ``options``, then the bus options."""
    parser = argparse.ArgumentParser(prog=f"aamtrack service {name}", description=description)
    add_options(parser, options)
    add_options(parser.add_argument_group("bus"), BusOptions)
    parser.add_argument("-v", "--verbose", action="store_true", help="log debug messages")
    return parser


def parse_service_args(name: str, description: str, options: type[Options],
                       argv: Sequence[str] | None = None) -> ServiceArgs:
    """Parse and check a service's arguments; exits 2 with one line naming a bad option."""
    parser = service_parser(name, description, options)
    args = parser.parse_args(argv)
    try:
        parsed = ServiceArgs(options_from(BusOptions, args), options_from(options, args),
                             args.verbose)
        if parsed.bus.keys:  # a keys file that cannot be used stops the service before it starts
            from services.bus.trust import read_keys_file  # numpy: not for --help

            try:
                read_keys_file(parsed.bus.keys)
            except ValueError as exc:
                raise OptionError(f"--keys: {exc}") from None
        return parsed
    except OptionError as exc:
        parser.error(str(exc))
        raise  # parser.error exits


def service_argv(bus: BusOptions, options: Options, verbose: bool = False) -> list[str]:
    """The arguments that give a service these options."""
    return options_argv(options) + options_argv(bus) + (["--verbose"] if verbose else [])
