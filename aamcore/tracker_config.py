"""The tracker's one configuration, as MediaPipe's tasks take one options object.

:class:`TrackerConfig` holds every choice of how faces are tracked, each with its
default and its help once: how a frame is fitted (:class:`~aamcore.fitting.config.FitterConfig`),
when a tracked frame is refitted (:class:`~aamcore.fitting.config.Refit`), which frames
without a face are searched (:class:`~aamcore.fitting.search.SearchSchedule`), how new
faces are looked for and ids kept (:class:`~aamcore.fitting.config.NewFaces`), how many
faces, where the warp runs, smoothing and the expression label's hold.

Everything else is made from it: the library's :class:`~aamcore.tracker.FaceTracker`
takes it (or its values by name: ``FaceTracker(max_faces=2)``); the fitter, pose and
expression services' options, ``aamtrack run``, ``aamtrack track`` and the stack file
offer each value under the flag :meth:`~aamcore.settings.Settings.settings` names
(``refit.every`` is ``--refit-every``, ``refit-every`` in a stack file), with its help
and checks. A new option is one :func:`~aamcore.settings.setting` in one of these
dataclasses.
"""

from __future__ import annotations

from dataclasses import dataclass

from aamcore import defaults
from aamcore.fitting.config import DEFAULT_REFIT, FITTER, FitterConfig, NewFaces, Refit
from aamcore.fitting.search import SearchSchedule
from aamcore.settings import Settings, group, setting

WARPS = ("auto", "gpu", "cpu")
"""Where the image warp runs (:class:`aamcore.fitting.warps.FitterWarp`)."""


@dataclass(frozen=True)
class TrackerConfig(Settings):
    """Every choice of how faces are tracked, with its default.

    Attributes
    ----------
    fitting : FitterConfig
        How each frame is fitted (flags without a prefix: ``--algorithm``).
    refit : Refit
        When a tracked frame is also fitted afresh from the mean face (``--refit-*``).
    search : SearchSchedule
        Which frames without a face are searched (``--search-*``).
    new_faces : NewFaces
        With several faces, how new ones are looked for and ids kept (``--new-faces-*``).
    max_faces, warp, smoothing, expression_hold
        As their help says.
    """

    fitting: FitterConfig = group(FITTER, "how each frame is fitted")
    refit: Refit = group(DEFAULT_REFIT, "when a tracked frame is also fitted afresh",
                         "refit")
    search: SearchSchedule = group(SearchSchedule(), "which frames without a face are "
                                   "searched", "search")
    new_faces: NewFaces = group(NewFaces(), "how new faces are looked for, ids kept and "
                                "faces forgotten", "new_faces")
    max_faces: int = setting(1, "track up to N faces per frame, each under its face_id "
                             "(1: the largest face)", low=1, high=defaults.MAX_FACES,
                             metavar="N")
    warp: str = setting("auto", "where the image warp runs: auto (the GPU worker thread on a "
                        "hardware GL renderer for a model of 20,000 reference pixels or more, "
                        "else the CPU), gpu (falls back to cpu) or cpu",
                        choices=WARPS)
    smoothing: bool = setting(True, "smooth the landmarks and the head pose over time (One "
                              "Euro filter)", flag="--smooth")
    expression_hold: int = setting(defaults.EXPRESSION_HOLD, "classified frames a new "
                                   "expression label must lead before it is shown (0: none)",
                                   low=0, high=1000, metavar="N")


TRACKER = TrackerConfig()
"""The defaults."""
