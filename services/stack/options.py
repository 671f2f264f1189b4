"""What ``aamtrack run`` is asked to do: the launcher's own options, the options tree and the
services' own.

``aamtrack run`` offers the whole options tree (:class:`~aamcore.operators.options.PipelineOptions`,
grouped by stage, over the profile's preset or a stack file's) and hands each service the
parts of its stage (:func:`with_stages`), with the source's and the Rerun logger's own
options: help, defaults, choices and range checks are written once, and the launcher
turns each service's options back into its command line
(:func:`services.bus.args.service_argv`).
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from aamcore.operators.options import PIPELINE, STAGES, PipelineOptions
from aamcore.profiles import PROFILES, profile_named
from services.bus.connection import DEFAULT_STREAM, BusOptions, check_fingerprint
from services.bus.options import (
    OptionError,
    Options,
    add_options,
    in_range,
    option,
    options_from,
)
from services.stack.drain import DRAIN_MAX, DRAIN_QUIET
from services.stack.registry import SERVICES

RUN_OPTIONS: dict[str, tuple[str, ...] | None] = {
    "source": None,
    "rerun": ("rrd", "serve", "viewer"),
}
"""The services' own options that ``aamtrack run`` offers (None: all of them), beside the
whole options tree (:class:`~aamcore.operators.options.PipelineOptions`), whose parts it
hands to the services of their stages."""
RUN_FLAGS: dict[str, dict[str, tuple[str, ...]]] = {
    "rerun": {"viewer": ("--connect",)},
}
"""Flags ``aamtrack run`` gives some of those options instead of the service's own.

``--connect`` of a service is its Zenoh endpoint; ``aamtrack run`` has none,
and there ``--connect [URL]`` streams to a Rerun viewer, as ``rerun --connect``.
"""
COMMON = {"source": ("video", "camera", "url", "pace"), "launch": ("profile", "smooth"),
          "pipeline": ("max_faces",), "rerun": ("rrd", "viewer")}
"""What ``aamtrack run --help`` shows first."""
ALWAYS = ("detector", "fitter", "pose", "expression")
"""Services every stack runs, beside the source."""


@dataclass(frozen=True)
class LaunchOptions(Options):
    """The launcher's own options."""

    profile: str = option("default", "the pipeline: default (local-binary landmarks, the AAM's "
                          "appearance and occlusion flags, contour pose, HOG + shape "
                          "expression) or thesis (fixed-Jacobian AAM, eq. 7.2, POSIT, LDA + "
                          "Mahalanobis on c); options given beside it override its choices",
                          choices=tuple(PROFILES))
    stream: str = option(DEFAULT_STREAM, "stream id")
    endpoint: str | None = option(None, "zenoh endpoint the stack listens on, for other "
                                  "programs to connect to (default: a Unix socket only this "
                                  "user can open, <private folder>/<stream>.sock; "
                                  "tcp/HOST:PORT opens the run to every local process)",
                                  metavar="ENDPOINT")
    ar: bool = option(True, "start the glasses renderer")
    record: str | None = option(None, "record every result message to FILE", metavar="FILE")
    record_images: bool = option(False, "with --record: frames and overlays too")
    summary: str | None = option(None, "write the run's summary as JSON", metavar="FILE")
    smooth: bool | None = option(None, "smooth over time in every stage: landmarks and pose "
                                 "(One Euro filter); --no-smooth also shows expression labels "
                                 "unheld and unaveraged (default: each stage's own options)")
    restart: bool = option(True, "restart services that die")
    start_timeout: float = option(120.0, "seconds to wait for the services to start",
                                  check=in_range(1))
    drain_quiet: float = option(DRAIN_QUIET, "after end of stream, seconds of quiet that end "
                                "the run",
                                check=in_range(0))
    drain_max: float = option(DRAIN_MAX, "seconds to wait for results after end of stream",
                              check=in_range(0))
    insecure: bool = option(False, "run even where a process of the run cannot keep its key "
                            "from other processes of this user (no prctl, a debugger "
                            "attached); the summary says so")
    trust: str = option("", "across hosts: the fingerprint the keys file's launcher key must "
                        "have (a keys file swapped for another is refused)", metavar="FP",
                        check=check_fingerprint)


@dataclass(frozen=True)
class StackOptions:
    """A whole run: the launcher's options, the services started with theirs, extra arguments.

    Attributes
    ----------
    launch : LaunchOptions
    services : dict of str to Options
        The services to start, by name, with their options (the source among them).
    extra : dict of str to list of str
        Extra command-line arguments per service (``--set SERVICE:ARG``).
    verbose : bool
    bus : BusOptions, optional
        For one host of a stack spread over several: the bus every process
        joins (a router's); None runs the whole stack on this machine.
    wait_for : tuple of str, optional
        The services the source waits for (default: the others started here).
    elsewhere : dict of str to tuple of str
        Across hosts: the services each other host runs; each must be heard from (a signed
        status) within the start timeout.
    tree : PipelineOptions, optional
        The options tree whose parts the services were given (None: the one their parts
        make).
    """

    launch: LaunchOptions = LaunchOptions()
    services: dict[str, Any] = field(default_factory=dict)
    extra: dict[str, list[str]] = field(default_factory=dict)
    verbose: bool = False
    bus: BusOptions | None = None
    wait_for: tuple[str, ...] | None = None
    elsewhere: dict[str, tuple[str, ...]] = field(default_factory=dict)
    tree: PipelineOptions | None = None

    def options(self, name: str) -> Any:
        """The options of service ``name`` (its defaults when it is not started)."""
        return self.services.get(name) or SERVICES[name].options()


def add_run_options(parser: argparse.ArgumentParser) -> None:
    """Add the launcher's options, the options tree grouped by stage and the services'
    :data:`RUN_OPTIONS` to ``parser``, the :data:`COMMON` ones first."""
    common = parser.add_argument_group("common options")
    source, rerun = SERVICES["source"].options, SERVICES["rerun"].options
    add_options(common, source, COMMON["source"])
    add_options(common, LaunchOptions, COMMON["launch"])
    add_options(common, PipelineOptions, COMMON["pipeline"])
    add_options(common, rerun, COMMON["rerun"], RUN_FLAGS["rerun"])
    add_options(parser, PipelineOptions, _but(PipelineOptions, COMMON["pipeline"]),
                by_stage=True)
    add_options(parser.add_argument_group("launcher"), LaunchOptions,
                _but(LaunchOptions, COMMON["launch"]))
    add_options(parser.add_argument_group("source"), source, _but(source, COMMON["source"]))
    add_options(parser.add_argument_group("rerun"), rerun,
                [n for n in RUN_OPTIONS["rerun"] or () if n not in COMMON["rerun"]],
                RUN_FLAGS["rerun"])
    parser.add_argument("--set", action="append", default=[], metavar="SERVICE:ARG",
                        help="extra argument for one service, e.g. fitter:--detect-timeout=2")


def _but(cls: type[Options], names: Sequence[str]) -> list[str]:
    return [s.name for s in cls.settings() if s.name not in names]


def extra_args(items: Sequence[str]) -> dict[str, list[str]]:
    """``--set SERVICE:ARG`` items by service.

    Raises
    ------
    OptionError
    """
    extra: dict[str, list[str]] = {}
    for item in items:
        name, sep, arg = item.partition(":")
        if not sep or name not in SERVICES or not arg:
            raise OptionError(f"--set {item!r}: expected SERVICE:ARG with SERVICE one of "
                              f"{', '.join(SERVICES)}")
        extra.setdefault(name, []).append(arg)
    return extra


def stack_options(args: argparse.Namespace, base: StackOptions | None = None) -> StackOptions:
    """The run asked for by parsed ``run`` arguments, over ``base`` (e.g. a stack file's).

    Raises
    ------
    OptionError
    """
    base = base or StackOptions()
    launch = options_from(LaunchOptions, args, base=base.launch)
    tree = (pipeline_of(base.services) if base.services
            else profile_named(launch.profile).options)
    tree = options_from(PipelineOptions, args, base=tree)
    if launch.smooth is not None:
        tree = tree.smoothed(launch.smooth)
    every = {name: with_stages(options_from(info.options, args, RUN_OPTIONS.get(name, ()),
                                            base=base.services.get(name),
                                            flags=RUN_FLAGS.get(name)), tree)
             for name, info in SERVICES.items()}
    if base.services:
        names = list(base.services)
    else:
        always = [n for n in ALWAYS if n != "expression" or tree.expression.enabled]
        names = ["source", *always, *(["ar"] if launch.ar else []),
                 *(["rerun"] if every["rerun"].has_output else [])]
    services = {name: every[name] for name in SERVICES if name in names}
    if "source" in services and not services["source"].has_input:
        raise OptionError("give the input: --video FILE, --camera INDEX or --url URL")
    services.update(keep_every_fit(services))
    extra = {**base.extra, **extra_args(getattr(args, "set", []) or [])}
    return StackOptions(launch, services, extra, bool(getattr(args, "verbose", False)),
                        base.bus, base.wait_for, base.elsewhere, tree)


def with_stages(options: Options, tree: PipelineOptions) -> Any:
    """A service's options with the parts of the options tree its stage takes (and the fit
    stage's rule for keeping faces, which every per-face state follows)."""
    parts = {f.name: getattr(tree, f.name) for f in dataclasses.fields(options)
             if f.name in STAGES and "group" in f.metadata}
    if any(f.name == "new_faces" for f in dataclasses.fields(options)):
        parts["new_faces"] = tree.fit.new_faces
    return options.replace(**parts) if parts else options


def pipeline_of(services: dict[str, Any]) -> PipelineOptions:
    """The options tree the services' parts make (the defaults for the parts of none)."""
    parts = {f.name: getattr(opts, f.name) for opts in services.values()
             for f in dataclasses.fields(opts) if f.name in STAGES and "group" in f.metadata}
    return PIPELINE.replace(**parts)


FAST_CAPACITY = 1024
"""Fits the pose and expression services keep while busy when the source is paced ``fast``."""


def keep_every_fit(services: dict[str, Any]) -> dict[str, Any]:
    """With ``fast`` pacing (a file as fast as the fitter answers), the pose and expression
    services left at their default capacity keep every fit (:data:`FAST_CAPACITY`): the
    fitter outruns the pose estimate, and a file processed fast should give every frame
    its pose and expression rather than the latest few."""
    source = services.get("source")
    if source is None or source.pace != "fast":
        return {}
    return {name: services[name].replace(capacity=FAST_CAPACITY)
            for name in ("pose", "expression")
            if name in services and services[name].capacity == SERVICES[name].options().capacity}


def from_stack_file(path: str, host: str | None = None) -> StackOptions:
    """The run of a stack file: every service on this machine, or those of ``host``.

    Raises
    ------
    OptionError
    """
    from services.stack.stack_file import read_stack_file

    stack = read_stack_file(path)
    services = stack.services_of(host)
    if not services:
        raise OptionError(f"--stack {path}: no service to run" + (f" on {host}" if host else ""))
    launch = LaunchOptions(stream=stack.stream, ar="ar" in services)
    if host is None:
        return StackOptions(launch, services)
    others = tuple(n for n in stack.services_of() if n != "source")
    return StackOptions(launch, services, bus=stack.bus(host), wait_for=others,
                        elsewhere=stack.elsewhere(host))


def parse_run_args(argv: Sequence[str]) -> StackOptions:
    """:func:`stack_options` of an ``aamtrack run`` command line (for tests and benches)."""
    parser = argparse.ArgumentParser(prog="aamtrack run")
    add_run_options(parser)
    return stack_options(parser.parse_args(list(argv)))


def pipeline(stack: StackOptions) -> PipelineOptions:
    """The options tree a run carries out (what :class:`aamcore.tracker.FaceTracker` takes
    for the same run)."""
    if stack.tree is not None:
        return stack.tree
    return pipeline_of({name: stack.options(name) for name in SERVICES})
