"""What ``aamtrack run`` is asked to do: the launcher's own options and each service's.

The services' options are their own dataclasses (``services/<name>/options.py``);
``aamtrack run`` offers the ones of :data:`RUN_OPTIONS` under the same flags,
so that help, defaults, choices and range checks are written once, and the
launcher turns each service's dataclass back into its command line
(:func:`services.bus.args.service_argv`).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from aamcore.profiles import PROFILES, Profile, profile_named
from aamcore.tracker_config import TrackerConfig
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

TRACKING = tuple(s.name for s in TrackerConfig.settings()
                 if s.name not in ("smoothing", "expression_hold"))
"""The tracker's values ``aamtrack run`` offers as the fitter's (smoothing is the launcher's
``--smooth``, the label hold the expression service's ``--expression-hold``)."""
RUN_OPTIONS: dict[str, tuple[str, ...] | None] = {
    "source": None,
    "fitter": ("model", "model_limit", "model_images", "model_update", *TRACKING),
    "pose": ("fov", "calibration", "estimator"),
    "expression": ("classifier", "hold"),
    "rerun": ("rrd", "serve", "viewer"),
}
"""The options of each service that ``aamtrack run`` offers (None: all of them)."""
RUN_FLAGS: dict[str, dict[str, tuple[str, ...]]] = {
    "expression": {"hold": ("--expression-hold",)},
    "rerun": {"viewer": ("--connect",)},
}
"""Flags ``aamtrack run`` gives some of those options instead of the service's own.

``--connect`` of a service is its Zenoh endpoint; ``aamtrack run`` has none,
and there ``--connect [URL]`` streams to a Rerun viewer, as ``rerun --connect``.
"""
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
    smooth: bool | None = option(None, "smooth landmarks and pose over time (One Euro filter) "
                                 "and hold expression labels (default: as the fitter, pose "
                                 "and expression services, on)")
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
    """

    launch: LaunchOptions = LaunchOptions()
    services: dict[str, Any] = field(default_factory=dict)
    extra: dict[str, list[str]] = field(default_factory=dict)
    verbose: bool = False
    bus: BusOptions | None = None
    wait_for: tuple[str, ...] | None = None
    elsewhere: dict[str, tuple[str, ...]] = field(default_factory=dict)

    def options(self, name: str) -> Any:
        """The options of service ``name`` (its defaults when it is not started)."""
        return self.services.get(name) or SERVICES[name].options()


def add_run_options(parser: argparse.ArgumentParser) -> None:
    """Add the launcher's options and the services' :data:`RUN_OPTIONS` to ``parser``."""
    add_options(parser, LaunchOptions)
    for name, only in RUN_OPTIONS.items():
        add_options(parser.add_argument_group(name), SERVICES[name].options, only,
                    RUN_FLAGS.get(name))
    parser.add_argument("--set", action="append", default=[], metavar="SERVICE:ARG",
                        help="extra argument for one service, e.g. fitter:--detect-timeout=2")


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
    profile = profile_named(launch.profile)
    every = {name: options_from(info.options, args, RUN_OPTIONS.get(name, ()),
                                base=profiled(name, base.services.get(name), profile),
                                flags=RUN_FLAGS.get(name))
             for name, info in SERVICES.items()}
    if base.services:
        names = list(base.services)
    else:
        names = ["source", *ALWAYS, *(["ar"] if launch.ar else []),
                 *(["rerun"] if every["rerun"].has_output else [])]
    services = {name: every[name] for name in SERVICES if name in names}
    if launch.smooth is not None:
        if "fitter" in services:
            fitter = services["fitter"]
            services["fitter"] = fitter.replace(
                tracking=fitter.tracking.replace(smoothing=launch.smooth))
        if "pose" in services:
            services["pose"] = services["pose"].replace(smooth=launch.smooth)
        if "expression" in services and not launch.smooth:
            services["expression"] = services["expression"].replace(hold=0)
    if "source" in services and not services["source"].has_input:
        raise OptionError("give the input: --video FILE, --camera INDEX or --url URL")
    services.update(keep_every_fit(services))
    extra = {**base.extra, **extra_args(getattr(args, "set", []) or [])}
    return StackOptions(launch, services, extra, bool(getattr(args, "verbose", False)),
                        base.bus, base.wait_for, base.elsewhere)


def profiled(name: str, options: Options | None, profile: Profile) -> Options:
    """Service ``name``'s options (its defaults, or a stack file's) with ``profile``'s
    choices; the command line's go over them."""
    options = options or SERVICES[name].options()
    if profile.name == "default":
        return options
    if name == "fitter":
        return options.replace(tracking=options.tracking.replace(fitting=profile.fitter),
                               model_update=profile.update_method)
    if name == "pose":
        return options.replace(estimator=profile.pose_estimator)
    return options


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


def tracker_config(stack: StackOptions) -> TrackerConfig:
    """The tracker's configuration a run carries out: the fitter's, with the expression
    service's label hold (what :class:`aamcore.tracker.FaceTracker` takes for the same
    run)."""
    return stack.options("fitter").tracking.replace(expression_hold=stack.options("expression")
                                                    .hold)
