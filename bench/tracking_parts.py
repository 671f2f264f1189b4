"""Tracking schemes compared per facial part on the generated sequences (see
``bench_tracking.py``): the tracker with or without refits from the mean face, and the
floors that refit every frame."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from aamcore.detection.haar import HaarFaceDetector
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.result import FitResult
from aamcore.fitting.tracker import Refit, Tracker, fit_upright
from aamcore.io.landmarks import LandmarkScheme
from aamcore.synth.motion_files import GroundTruth

RIGHT = 0.08
"""A good fit with an NME under this is on the face (the re-acquisition criterion)."""
PARTS = ("all", "jaw", "brows", "nose", "eyes", "mouth")
"""The columns: every point, then the scheme's groups of these names."""


@dataclass(frozen=True)
class Scheme:
    """A way to fit every frame of a sequence.

    Attributes
    ----------
    name : str
    refit : Refit or None
        The :class:`~aamcore.fitting.tracker.Tracker`'s refits (a tracker scheme).
    start : {"truth", "previous"} or None
        A floor instead: every frame fitted from the mean face placed on this frame's true
        landmarks, or on the previous frame's fit (the first frame's truth to begin).
    then_track : bool
        A floor's fit tracked once more.
    upright : bool
        A floor's fit made in the frame turned upright about the face
        (:func:`~aamcore.fitting.tracker.fit_upright`).
    """

    name: str
    refit: Refit | None = None
    start: str | None = None
    then_track: bool = False
    upright: bool = False


def parse_scheme(text: str) -> Scheme:
    """A scheme from its name: ``track``; ``truth``, ``previous`` (floors), either with
    ``+track``, ``+upright`` or both (``truth+upright+track``); or
    ``refit:every=N,score=S,moving=M,failed=1,then=1`` (any value of
    :class:`~aamcore.fitting.config.Refit` by its name)."""
    if text == "track":
        return Scheme(text, Refit())
    base, *plus = text.split("+")
    if base in ("truth", "previous") and set(plus) <= {"track", "upright"}:
        return Scheme(text, start=base, then_track="track" in plus, upright="upright" in plus)
    kind, _, options = text.partition(":")
    if kind != "refit" or not options:
        raise ValueError(f"unknown scheme {text!r}")
    known = {s.name: s for s in Refit.settings()}  # every value of Refit, as declared
    known["then"] = known["then_track"]
    fields: dict[str, float | bool | int] = {}
    for item in options.split(","):
        key, _, value = item.partition("=")
        if key not in known:
            raise ValueError(f"scheme {text!r}: unknown option {key!r}")
        s = known[key]
        fields[s.name] = value not in ("0", "") if s.kind is bool else s.kind(value)
    return Scheme(text, Refit().with_values(**fields))


@dataclass(frozen=True)
class Run:
    """A scheme's fits of one sequence.

    Attributes
    ----------
    ok : (F,) bool array
        A good fit (it passed the failure test).
    landmarks : (F, N, 2) array
        NaN without a fit.
    seconds : (F,) array
    refits, kept : int
        A tracker scheme's refits run and kept (0 for a floor).
    """

    ok: np.ndarray
    landmarks: np.ndarray
    seconds: np.ndarray
    refits: int = 0
    kept: int = 0


def run_scheme(scheme: Scheme, fitter: Fitter, frames: list[np.ndarray],
               truth: GroundTruth) -> Run:
    """Fit every frame of a sequence by ``scheme``, timing each frame."""
    n_points = truth.landmarks.shape[1]
    ok = np.zeros(len(frames), bool)
    points = np.full((len(frames), n_points, 2), np.nan)
    seconds = np.zeros(len(frames))
    step: Callable[[int, np.ndarray], FitResult | None]
    tracker = None
    if scheme.refit is not None:
        tracker = Tracker(fitter, HaarFaceDetector(), refit=scheme.refit)
        step = lambda k, frame: tracker.track(frame)  # noqa: E731
    else:
        previous = [truth.landmarks[0]]

        def step(k: int, frame: np.ndarray) -> FitResult | None:
            start = truth.landmarks[k] if scheme.start == "truth" else previous[0]
            fit = fitter.fit_shape(frame, start) if not scheme.upright else fit_upright(
                fitter, frame, start)
            if scheme.then_track and fit.ok:
                tracked = fitter.track(frame, fit)
                fit = tracked if tracked.ok else fit
            if fit.ok:
                previous[0] = fit.points
            return fit

    for k, frame in enumerate(frames):
        t0 = time.perf_counter()
        fit = step(k, frame)
        seconds[k] = time.perf_counter() - t0
        if fit is not None:
            ok[k] = fit.ok
            points[k] = fit.points
    refits, kept = (tracker.refits, tracker.kept) if tracker is not None else (0, 0)
    return Run(ok, points, seconds, refits, kept)


def part_errors(run: Run, truth: GroundTruth, scheme: LandmarkScheme) -> dict[str, np.ndarray]:
    """Per part of :data:`PARTS`, the NME (G,) of the good fits outside the occluder: the
    part's mean point error over the truth's outer-eye-corner distance."""
    use = run.ok & ~truth.occluded
    fit, gt = run.landmarks[use], truth.landmarks[use]
    a, b = scheme.eye_corners
    iod = np.linalg.norm(gt[:, a] - gt[:, b], axis=1)
    dist = np.linalg.norm(fit - gt, axis=2)
    out = {}
    for part in PARTS:
        index = list(range(scheme.n_points)) if part == "all" else list(scheme.groups[part])
        out[part] = dist[:, index].mean(axis=1) / iod
    return out


@dataclass
class Pool:
    """Several sequences' numbers of one scheme, pooled."""

    errors: dict[str, list[np.ndarray]]
    seconds: list[np.ndarray]
    common: list[np.ndarray] = field(default_factory=list)
    """NME (all points) of the frames where every scheme compared has a good fit."""
    good: int = 0
    right: int = 0
    """Good fits with an NME under :data:`RIGHT`."""
    outside: int = 0
    refits: int = 0
    kept: int = 0
    frames: int = 0

    @classmethod
    def empty(cls) -> Pool:
        return cls({part: [] for part in PARTS}, [])

    def add(self, run: Run, truth: GroundTruth, scheme: LandmarkScheme) -> None:
        errors = part_errors(run, truth, scheme)
        for part, e in errors.items():
            self.errors[part].append(e)
        self.right += int(np.sum(errors["all"] < RIGHT))
        self.seconds.append(run.seconds)
        self.good += int(np.sum(run.ok & ~truth.occluded))
        self.outside += int(np.sum(~truth.occluded))
        self.refits += run.refits
        self.kept += run.kept
        self.frames += len(run.ok)

    def add_common(self, run: Run, truth: GroundTruth, scheme: LandmarkScheme,
                   common: np.ndarray) -> None:
        """The NME of the frames ``common`` (F,) marks, where every scheme has a good fit."""
        self.common.append(part_errors(Run(common, run.landmarks, run.seconds), truth,
                                       scheme)["all"])

    def mean(self, part: str) -> float:
        e = np.concatenate(self.errors[part]) if self.errors[part] else np.zeros(0)
        return float(e.mean()) if len(e) else math.nan


HEADER = (f"{'scheme':<40}{'good out':>9}{'<0.08':>7}"
          + "".join(f"{p + ' mean/p95':>17}" for p in PARTS)
          + f"{'common':>8}{'ms mean':>8}{'ms med':>7}{'refits':>7}{'kept':>6}")


def pool_row(name: str, pool: Pool) -> str:
    """One table line: good fits outside the occluder (all, and those with an NME under
    :data:`RIGHT`), NME mean/p95 per part, the mean NME of the frames every scheme fits well,
    time, refits."""
    def cell(part: str) -> str:
        e = np.concatenate(pool.errors[part]) if pool.errors[part] else np.zeros(0)
        if not len(e):
            return f"{'-':>17}"
        return f"{e.mean():>10.4f}/{np.percentile(e, 95):.4f}"

    ms = 1000 * np.concatenate(pool.seconds) if pool.seconds else np.zeros(0)
    good = f"{pool.good / pool.outside:.1%}" if pool.outside else "-"
    right = f"{pool.right / pool.outside:.1%}" if pool.outside else "-"
    refit = f"{pool.refits / pool.frames:.0%}" if pool.frames else "-"
    kept = f"{pool.kept / pool.refits:.0%}" if pool.refits else "-"
    common = np.concatenate(pool.common) if pool.common else np.zeros(0)
    shared = f"{common.mean():>8.4f}" if len(common) else f"{'-':>8}"
    return (f"{name[:39]:<40}{good:>9}{right:>7}" + "".join(cell(p) for p in PARTS) + shared
            + f"{ms.mean():>8.2f}{np.median(ms):>7.2f}{refit:>7}{kept:>6}")
