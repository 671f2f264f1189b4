"""How the fitting stage fits and tracks: the parts of the tracker's one configuration.

:class:`FitterConfig` (how a frame is fitted), :class:`Refit` (when a tracked frame is
also fitted afresh) and :class:`NewFaces` (how several faces are looked for and keep
their ids), with :class:`~aamcore.fitting.search.SearchSchedule`, are the fitting
groups of :class:`~aamcore.operators.options.FitOptions`, each value declared once with
its default and help (:func:`aamcore.settings.setting`). Light to import: option
parsers read it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from aamcore import defaults
from aamcore.fitting.algorithm import ALGORITHMS
from aamcore.settings import ConfigError, Settings, setting

FAILURE_TESTS = defaults.FAILURE_TESTS
"""How a failed fit is recognised (:mod:`aamcore.fitting.failure`)."""
REFINERS = ("fixed-jacobian", "supervised-descent")
"""The AAM methods that can refine a regressor's landmarks (``refine_with``)."""


@dataclass(frozen=True)
class FitterConfig(Settings):
    """The fitting stage's choices (:class:`~aamcore.fitting.fitter.Fitter`).

    Attributes
    ----------
    algorithm : str
        A name of :data:`aamcore.fitting.algorithm.ALGORITHMS`.
    failure_test : str
        One of :data:`FAILURE_TESTS`.
    appearance : bool
        Give every good fit the AAM's appearance (an
        :class:`~aamcore.fitting.result.AAMFit`): a landmark regressor's fits are
        sampled into the reference frame and projected (one texture warp each). The AAM
        methods compute it whatever this says.
    occlusion : bool or None
        Judge per landmark whether the face there is covered, from the texture residual
        around it (needs the appearance and a model with an occlusion part); None: wherever
        there is an appearance. True with ``appearance`` False is refused.
    refine : int
        After a regressor's landmarks, this many iterations of ``refine_with`` (0: none).
    refine_with : str
        One of :data:`REFINERS`.
    max_iterations : int or None
        Iteration limit of the iterative AAM methods (None: each has its own).
    """

    algorithm: str = setting(defaults.ALGORITHM, "fitting algorithm",
                             choices=tuple(ALGORITHMS))
    failure_test: str = setting(defaults.FAILURE_TEST, "how a failed fit is recognised (auto: "
                                "the learned quality score for local-binary, chi2 for the AAM "
                                "methods)", choices=FAILURE_TESTS)
    appearance: bool = setting(True, "give every good fit the AAM's appearance (c, texture "
                               "residual, occlusion flags): a landmark regressor's fits "
                               "(local-binary) are sampled and projected, one texture warp "
                               "each")
    occlusion: bool | None = setting(None, "flag the landmarks whose part of the face is "
                                     "covered, from the texture residual around them "
                                     "(default: wherever there is an appearance)")
    refine: int = setting(0, "after a regressor's landmarks, this many iterations of "
                          "--refine-with (0: none)", low=0, high=100, metavar="N")
    refine_with: str = setting("fixed-jacobian", "the AAM method that refines: the "
                               "fixed-Jacobian update, or the supervised-descent cascade's "
                               "last stages", choices=REFINERS)
    max_iterations: int | None = setting(None, "iteration limit of the iterative AAM methods "
                                         "(default: each method's own)", low=1, high=1000,
                                         metavar="N")

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.occlusion and not self.appearance:
            raise ConfigError("occlusion", True, "needs the appearance, whose texture residual "
                              "the flags are read from (appearance is False)")

    @property
    def judges_occlusion(self) -> bool:
        """Whether occlusion is judged where there is an appearance."""
        return self.occlusion is not False


@dataclass(frozen=True)
class Refit(Settings):
    """When the tracker also refits a frame from the mean face placed on its landmarks.

    Tracking from the previous frame's landmarks follows the head but keeps whatever error
    it has where the face changes shape (the jaw and the mouth as the expression changes);
    a fit from the mean face, placed by a similarity on the tracked landmarks, starts
    afresh (the whole cascade, as on a detection) and costs as much. A refit is kept
    instead of the tracked fit when it passes the failure test and its quality score (the
    predicted log NME) is lower; a fitter without that score (a failure test other than
    ``quality``) never refits.

    Attributes
    ----------
    every, score, moving, failed, then_track
        As their help says.
    """

    every: int = setting(0, "refit every N tracked frames (0: not by count)", low=0,
                         metavar="N")
    score: float = setting(math.inf, "refit a tracked fit whose quality score (predicted log "
                           "NME) is above this (inf: never)", metavar="SCORE")
    moving: float = setting(math.inf, "refit when the face moved more than this share of its "
                            "width since the last frame (inf: never)", low=0, metavar="SHARE")
    disagreement: float = setting(math.inf, "refit a tracked fit whose two fits (from the last "
                                  "landmarks, and afresh) lay further apart than this share "
                                  "of the eye distance (inf: never)", low=0, metavar="SHARE")
    failed: bool = setting(False, "refit from the last good fit's landmarks when tracking "
                           "fails, before a detection")
    then_track: bool = setting(False, "track once more from a refit kept (the fern stages "
                               "polish its landmarks)")

    @property
    def never(self) -> bool:
        return (self.every <= 0 and self.score == math.inf and self.moving == math.inf
                and self.disagreement == math.inf and not self.failed)


NEVER = Refit()
"""Track only."""
DEFAULT_REFIT = Refit(failed=True)
"""The tracker's default: a refit from the mean face only where tracking fails, before a
detection. The default cascade's tracking already averages a fit from the last landmarks
with one afresh from the mean placed on them (the restart stages), so refits by count buy
little: ``bench/bench_tracking.py --parts-only --per-set 4 --nonrigid 4`` (recipe fitting
v12) measured on the non-rigid sequences mean NME 0.0486 tracking alone, 0.0487 with this
default, 0.0479 with a refit every sixth frame, at 2.19, 2.20 and 3.10 ms a frame on
average; on the rigid ones 0.0518, 0.0513 and 0.0506 with 84.1 %, 83.8 % and 83.5 % of the
frames outside the occluder fitted well, at 3.83, 3.90 and 4.67 ms. Before the restart
stages a refit every sixth frame took the non-rigid sequences from 0.0644 to 0.0506."""


@dataclass(frozen=True)
class NewFaces(Settings):
    """How a tracker of several faces looks for new ones and keeps ids.

    Attributes
    ----------
    every : int
        Search for faces not yet tracked every this many frames while fewer than
        ``max_faces`` are tracked, upright and in the frame turned by 25 degrees in turn
        (every fifth frame: the search costs 0.97 ms a frame on average at 960x540,
        ``bench/bench_multiface.py``).
    regain_frames, regain_distance
        A face found again within ``regain_frames`` of being lost and within
        ``regain_distance`` of its width of where it was lost keeps its id; any other face
        found gets a new one.
    overlap : float
        Two tracked faces whose landmark boxes overlap more than this (intersection over
        the smaller box) are one face: the one that moved less keeps it.
    hidden_frames : int
        A face lost where it overlapped another (gone behind it) is looked for around the
        place it was lost on every frame, and keeps its id, for this many frames; then it
        is forgotten, with its per-face state (smoothing, pose, expression) in the library
        and the services alike.
    """

    every: int = setting(5, "with several faces, search for new ones every N frames",
                         low=1, metavar="N")
    regain_frames: int = setting(15, "a face found again within N frames of being lost ...",
                                 low=0, metavar="N")
    regain_distance: float = setting(0.5, "... and within this share of its width of where "
                                     "it was lost keeps its id", low=0, metavar="SHARE")
    overlap: float = setting(0.5, "two faces whose landmark boxes overlap more than this "
                             "(of the smaller box) are one", above=0, high=1, metavar="SHARE")
    hidden_frames: int = setting(90, "a face lost behind another keeps its id (and its state) "
                                 "for N frames", low=0, metavar="N")

    @property
    def forget_frames(self) -> int:
        """Frames after which a face not seen is forgotten, its state with it: as long as
        its id can be regained."""
        return max(self.regain_frames, self.hidden_frames)


FITTER = FitterConfig()
"""The defaults."""
