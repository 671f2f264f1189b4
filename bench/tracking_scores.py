"""Per-frame results of the tracking bench and their scores: good fits, NME against the
truth, re-acquisition after the occluder (see ``bench_tracking.py``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aamcore.evaluation.metrics import nme
from aamcore.io.landmarks import LandmarkScheme
from aamcore.synth.motion_files import GroundTruth
from aamcore.tracker import FaceResult

REACQUIRED_NME = 0.08
"""A good fit re-acquires the face when its NME is below this."""

@dataclass(frozen=True)
class Track:
    """What the tracker did on every frame of a clip.

    Attributes
    ----------
    success : (F,) bool array
        A face was found and its fit passed the failure test.
    found : (F,) bool array
        A face was found (a fit was returned, good or failed).
    landmarks : list of (N, 2) arrays
        ``(0, 2)`` without a face.
    seconds : (F,) float array
        Time of each frame; NaN when not measured (the stack).
    detections : int
        Detector runs.
    """

    success: np.ndarray
    found: np.ndarray
    landmarks: list[np.ndarray]
    seconds: np.ndarray
    detections: int


@dataclass(frozen=True)
class Score:
    """A clip's (or a pool of clips') numbers.

    Attributes
    ----------
    frames, good, outside, good_outside, failed, no_face, redetections : int
        Frame counts (``outside``: frames without the occluder on the face).
    errors : (G,) float array
        NME of the good fits outside the occluder (empty without a truth).
    reacquire : list of int or None
        Frames to re-acquire after each occluder (None: never).
    seconds : (F,) float array
    """

    frames: int
    good: int
    outside: int
    good_outside: int
    failed: int
    no_face: int
    redetections: int
    errors: np.ndarray
    reacquire: list[int | None]
    seconds: np.ndarray


def track_of(results: list[FaceResult], seconds: np.ndarray, detections: int) -> Track:
    """A :class:`Track` of per-frame results."""
    return Track(np.array([r.success for r in results], bool),
                 np.array([len(r.landmarks) > 0 for r in results], bool),
                 [r.landmarks for r in results], seconds, detections)


def frame_errors(run: Track, truth: GroundTruth, scheme: LandmarkScheme) -> np.ndarray:
    """NME of every frame with a good fit (F,); NaN elsewhere."""
    return np.array([nme(points, gt, scheme) if ok else np.nan
                     for ok, points, gt in zip(run.success, run.landmarks, truth.landmarks,
                                               strict=True)])


def reacquisition(run: Track, truth: GroundTruth, errors: np.ndarray) -> list[int | None]:
    """Frames from the occluder leaving the face to a good fit with NME < 0.08 ([] without an
    occluder; None: never)."""
    if not truth.occluded.any():
        return []
    after = int(np.flatnonzero(truth.occluded)[-1]) + 1
    for k in range(after, len(errors)):
        if run.success[k] and errors[k] < REACQUIRED_NME:
            return [k - after]
    return [None]


def score(run: Track, truth: GroundTruth | None, scheme: LandmarkScheme | None) -> Score:
    """The numbers of one clip."""
    frames = len(run.success)
    failed = int(np.sum(run.found & ~run.success))
    no_face = int(np.sum(~run.found))
    redetections = max(run.detections - 1, 0) if run.detections >= 0 else -1
    if truth is None or scheme is None:
        return Score(frames, int(run.success.sum()), frames, int(run.success.sum()), failed,
                     no_face, redetections, np.zeros(0), [], run.seconds)
    if len(truth.landmarks) != frames:
        raise ValueError(f"{frames} frames tracked, {len(truth.landmarks)} in the ground truth")
    errors = frame_errors(run, truth, scheme)
    outside = ~truth.occluded
    good_outside = run.success & outside
    return Score(frames, int(run.success.sum()), int(outside.sum()), int(good_outside.sum()),
                 failed, no_face, redetections, errors[good_outside],
                 reacquisition(run, truth, errors), run.seconds)


def pooled(scores: list[Score]) -> Score:
    """One score of several clips: frames pooled, every re-acquisition kept."""
    def total(name: str) -> int:
        return sum(getattr(s, name) for s in scores)

    return Score(total("frames"), total("good"), total("outside"), total("good_outside"),
                 total("failed"), total("no_face"), total("redetections"),
                 np.concatenate([s.errors for s in scores]),
                 [r for s in scores for r in s.reacquire],
                 np.concatenate([s.seconds for s in scores]))
