"""The options of ``aamtrack track``: the model, the expression classifier, the camera and the
tracker's configuration (:class:`aamcore.tracker_config.TrackerConfig`, every value under the
flag ``aamtrack run`` and the fitter service give it), light to import."""

from __future__ import annotations

import argparse
from dataclasses import dataclass

from aamcore.profiles import PROFILES, profile_named
from aamcore.tracker_config import TRACKER, TrackerConfig
from services.bus.options import (
    Options,
    add_options,
    in_range,
    option,
    options_from,
    settings_option,
)


@dataclass(frozen=True)
class TrackOptions(Options):
    """What ``aamtrack track`` runs the library's :class:`~aamcore.tracker.FaceTracker` with."""

    profile: str = option("default", "the pipeline whose model, fitting, head-pose estimator "
                          "and expression classifier are used, unless given here",
                          choices=tuple(PROFILES))
    model: str | None = option(None, "fitting model file (default: the profile's model, "
                               "trained and cached on first use)", metavar="FILE")
    classifier: str | None = option(None, "expression classifier file (default: the "
                                    "profile's for the model, trained and cached on first "
                                    "use)", metavar="FILE")
    expression: bool = option(True, "recognise expressions (--no-expression: none, nothing "
                              "trained for them)")
    fov: float | None = option(None, "assumed horizontal field of view, degrees",
                               check=in_range(1, 179))
    calibration: str | None = option(None, "camera calibration file", metavar="FILE")
    tracking: TrackerConfig = settings_option(TRACKER)


def add_track_options(parser: argparse.ArgumentParser) -> None:
    """Add :class:`TrackOptions` to ``parser``."""
    add_options(parser, TrackOptions)


def track_options(args: argparse.Namespace) -> TrackOptions:
    """The checked options of parsed ``track`` arguments; the profile's fitting under the
    values given.

    Raises
    ------
    OptionError
    """
    profile = profile_named(getattr(args, "profile", None) or "default")
    base = TrackOptions(tracking=TRACKER.replace(fitting=profile.fitter))
    return options_from(TrackOptions, args, base=base)
