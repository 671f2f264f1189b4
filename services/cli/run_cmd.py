"""Commands that run the stack or one of its services: ``run`` and ``service``.

- ``aamtrack run --video FILE [--rrd out.rrd]``: the whole stack on one host
  (:mod:`services.stack.launcher`); ``--stack FILE [--host NAME]`` takes the
  services and their options from a stack file.
- ``aamtrack service NAME [ARGS...]``: one service alone, e.g. on another
  machine (``aamtrack service fitter --connect tcp/10.0.0.2:7447``), or
  ``aamtrack service NAME --stack FILE --host HOST`` as a stack file says.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from services.bus.options import OptionError
from services.cli.commands import add_command
from services.stack.options import add_run_options, from_stack_file, stack_options
from services.stack.registry import SERVICES


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``run`` and ``service``."""
    from aamcore.results import columns_notes

    p = add_command(subparsers, "run",
                    description="Start every service as its own process, run until the end "
                    "of the input, stop them all and print a summary.", epilog=columns_notes())
    p.add_argument("--stack", metavar="FILE", help="take the services and their options from "
                   "a stack file (deploy/stack.toml); options given here override it")
    p.add_argument("--host", help="with --stack: run only this host's services, joined to "
                   "the file's router")
    add_run_options(p)
    p.set_defaults(func=cmd_run)
    p = add_command(subparsers, "service",
                              description="Run one service; its arguments follow its name "
                              "(aamtrack service fitter --help).")
    p.add_argument("name", choices=list(SERVICES), help="the service")
    p.add_argument("args", nargs=argparse.REMAINDER, help="the service's own arguments, or "
                   "--stack FILE --host HOST to take them from a stack file")
    p.set_defaults(func=cmd_service)


def cmd_run(args: argparse.Namespace) -> int:
    """``aamtrack run``."""
    from services.stack.launcher import run_stack
    from services.stack.outcome import EXIT_INPUT

    try:
        if args.host and not args.stack:
            raise OptionError("--host goes with --stack")
        base = from_stack_file(args.stack, args.host) if args.stack else None
        opts = stack_options(args, base)
    except OptionError as exc:
        print(f"aamtrack run: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    return run_stack(opts)


def _stack_file_argv(name: str, argv: list[str]) -> list[str]:
    """``--stack FILE [--host HOST]`` replaced by the service's options and bus from the file."""
    from services.bus.args import service_argv
    from services.stack.stack_file import read_stack_file

    parser = argparse.ArgumentParser(add_help=False)
    parser.add_argument("--stack")
    parser.add_argument("--host")
    known, rest = parser.parse_known_args(argv)
    if known.stack is None:
        return argv
    stack = read_stack_file(known.stack)
    options = stack.services.get(name) or SERVICES[name].options()
    if known.host is None:
        return service_argv(stack.bus(_host_of(stack, name)), options) + rest
    return service_argv(stack.bus(known.host), options) + rest


def _host_of(stack: object, name: str) -> str:
    for host in stack.hosts.values():  # type: ignore[attr-defined]
        if name in host.services:
            return host.name
    raise OptionError(f"no host of the stack file runs {name}: give --host")


def cmd_service(args: argparse.Namespace) -> int:
    """``aamtrack service NAME ARGS...``."""
    argv = list(args.args)
    if argv[:1] == ["--"]:
        argv = argv[1:]
    service = SERVICES[args.name]
    if {"-h", "--help"} & set(argv) and "--stack" not in argv:  # help without the service's code
        from services.bus.args import service_parser

        service_parser(args.name, service.summary, service.options).print_help()
        return 0
    try:
        argv = _stack_file_argv(args.name, argv)
    except OptionError as exc:
        print(f"aamtrack service {args.name}: error: {exc}", file=sys.stderr)
        return 2
    if args.verbose and "--verbose" not in argv:
        argv.append("--verbose")
    return int(importlib.import_module(service.module).main(argv) or 0)
