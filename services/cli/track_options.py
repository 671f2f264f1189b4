"""The options of ``aamtrack track``: a profile and the options tree
(:class:`aamcore.operators.options.PipelineOptions`, every value under the flag ``aamtrack
run`` and the services give it, grouped by stage), light to import."""

from __future__ import annotations

import argparse
from dataclasses import dataclass

from aamcore.operators.options import PipelineOptions
from aamcore.profiles import PROFILES, profile_named
from services.bus.options import Options, add_options, option, options_from


@dataclass(frozen=True)
class TrackOptions(Options):
    """What ``aamtrack track`` runs the library's :class:`~aamcore.tracker.FaceTracker` with,
    beside the options tree."""

    profile: str = option("default", "the pipeline whose options (model, fitting, head-pose "
                          "estimator, expression classifier) are used, unless given here",
                          choices=tuple(PROFILES))
    smooth: bool | None = option(None, "smooth over time in every stage (--no-smooth: every "
                                 "stage's raw answers; default: each stage's own options)")


def add_track_options(parser: argparse.ArgumentParser) -> None:
    """Add :class:`TrackOptions` and the options tree to ``parser``."""
    add_options(parser, TrackOptions)
    add_options(parser, PipelineOptions, by_stage=True)


def track_options(args: argparse.Namespace) -> tuple[TrackOptions, PipelineOptions]:
    """The checked options of parsed ``track`` arguments: the profile's options under the
    values given.

    Raises
    ------
    OptionError
    """
    opts = options_from(TrackOptions, args)
    tree = options_from(PipelineOptions, args, base=profile_named(opts.profile).options)
    return opts, tree if opts.smooth is None else tree.smoothed(opts.smooth)
