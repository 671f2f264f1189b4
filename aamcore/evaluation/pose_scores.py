"""Pose estimators scored on tracked sweeps: angle and distance errors, glasses anchors, time.

An *estimator* is any function ``estimate(landmarks (68, 2), camera) -> PoseLike``
(:class:`aamcore.pose.robust.ContourPose.estimate`, a POSIT on a subset, ...)
that may raise :class:`~aamcore.pose.errors.PoseError` for bad input.
:func:`evaluate_estimator` runs one on every frame of some
:class:`~aamcore.evaluation.pose_sweeps.TrackedSweep` and gives, per sweep and over all,
the error statistics of the reliable frames (roll, pitch, yaw in degrees,
distance in cm), how many frames were flagged or got no pose and why, the
time per estimate, and the reprojection error of the AR glasses' anchor
points under the estimated against the true pose: what a viewer sees.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from aamcore.evaluation.pose import error_statistics, pose_parameters, signed_errors
from aamcore.evaluation.pose_sweeps import TrackedSweep
from aamcore.pose.errors import PoseError
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.reliability import reason_key
from aamcore.synth.sequence import PoseTruth


class PoseLike(Protocol):
    """What an estimator returns: a pose and whether to trust it."""

    R: np.ndarray
    T: np.ndarray
    reliable: bool
    reason: str


Estimator = Callable[[np.ndarray, CameraIntrinsics], PoseLike]
"""``estimate(landmarks (68, 2), camera) -> PoseLike``; may raise PoseError for bad input."""
NO_LANDMARKS = "no landmarks"


def anchor_reprojection_px(
    anchors: np.ndarray, camera: CameraIntrinsics, estimate: PoseLike, truth: PoseTruth
) -> float:
    """Mean pixel distance between anchors projected with the estimated and the true pose.

    Parameters
    ----------
    anchors : (K, 3) array
        Points in the head model's frame, mm.
    camera : CameraIntrinsics
    estimate : PoseLike
    truth : PoseTruth
    """
    est = camera.project(anchors, estimate.R, estimate.T)
    true = camera.project(anchors, truth.R, truth.T)
    return float(np.linalg.norm(est - true, axis=1).mean())


@dataclass
class SweepResult:
    """An estimator's results on one sweep (or on all sweeps together).

    Attributes
    ----------
    name : str
    frames : int
    estimated : int
        Frames with a reliable pose.
    unreliable : int
        Frames whose pose was flagged unreliable.
    no_pose : int
        Frames without landmarks, or where the estimator refused them (PoseError).
    errors : dict
        Per parameter (roll, pitch, yaw in degrees, distance_cm): mean, std,
        mae, max_abs of the reliable frames' signed errors.
    anchor_px_mean, anchor_px_max : float
        Glasses anchor reprojection error of the reliable frames, pixels.
    reasons : dict of str to int
        Why frames were unreliable or got no pose (short keys).
    covered : tuple of float
        Smallest and largest true value of the swept parameter among reliable
        frames (degrees, or cm for distance); NaN without any.
    per_frame : (F, 4) array
        Signed errors per frame (NaN where no reliable pose).
    """

    name: str
    frames: int
    estimated: int
    unreliable: int
    no_pose: int
    errors: dict[str, dict[str, float]]
    anchor_px_mean: float
    anchor_px_max: float
    reasons: dict[str, int]
    covered: tuple[float, float]
    per_frame: np.ndarray


@dataclass
class _Frames:
    """What one sweep's frames gave: errors (F, 4), anchor px (F,), swept value (F,)."""

    errors: np.ndarray
    anchor: np.ndarray
    swept: np.ndarray
    unreliable: int = 0
    no_pose: int = 0
    reasons: Counter[str] | None = None

    def result(self, name: str) -> SweepResult:
        ok = ~np.isnan(self.errors[:, 0])
        any_ok = bool(ok.any())
        nan = float("nan")
        return SweepResult(
            name, len(self.errors), int(ok.sum()), self.unreliable, self.no_pose,
            error_statistics(self.errors[ok]),
            float(np.nanmean(self.anchor)) if any_ok else nan,
            float(np.nanmax(self.anchor)) if any_ok else nan, dict(self.reasons or {}),
            (float(self.swept[ok].min()), float(self.swept[ok].max())) if any_ok else (nan, nan),
            self.errors)


def _swept_value(pose: PoseTruth, parameter: str) -> float:
    p = pose_parameters(pose.R, pose.T)
    return p["distance_cm"] if parameter == "distance" else p.get(parameter, 0.0)


def _run_sweep(
    estimate: Estimator, sweep: TrackedSweep, marks: Sequence[np.ndarray | None],
    camera: CameraIntrinsics, anchors: np.ndarray, times: list[float],
    settle: Callable[[], object] | None, clock: Callable[[], float] = time.perf_counter,
) -> _Frames:
    """Estimate every frame of one sweep; append each estimate's seconds to ``times``."""
    n = len(sweep.poses)
    out = _Frames(np.full((n, 4), np.nan), np.full(n, np.nan),
                  np.array([_swept_value(p, sweep.spec.parameter) for p in sweep.poses]),
                  reasons=Counter())
    assert out.reasons is not None
    for i, (lm, truth) in enumerate(zip(marks, sweep.poses, strict=True)):
        if lm is None:
            out.no_pose += 1
            out.reasons[NO_LANDMARKS] += 1
            continue
        started = clock()
        try:
            est = estimate(lm, camera)
        except PoseError as exc:
            times.append(clock() - started)
            out.no_pose += 1
            out.reasons[reason_key(str(exc))] += 1
            continue
        times.append(clock() - started)
        if settle is not None:
            settle()
        if not est.reliable:
            out.unreliable += 1
            out.reasons[reason_key(est.reason)] += 1
            continue
        out.errors[i] = signed_errors(pose_parameters(est.R, est.T),
                                      pose_parameters(truth.R, truth.T))
        out.anchor[i] = anchor_reprojection_px(anchors, camera, est, truth)
    return out


def evaluate_estimator(
    estimate: Estimator,
    sweeps: Sequence[TrackedSweep],
    camera: CameraIntrinsics,
    anchors: np.ndarray,
    landmarks: Sequence[Sequence[np.ndarray | None]] | None = None,
    settle: Callable[[], object] | None = None,
    clock: Callable[[], float] = time.perf_counter,
) -> tuple[dict[str, SweepResult], dict[str, float]]:
    """Run an estimator on every frame of every sweep, in order, and compare with the truth.

    Parameters
    ----------
    estimate : callable
        ``estimate(landmarks (68, 2), camera) -> PoseLike``; a PoseError
        counts as a frame without a pose (with its message as the reason).
    sweeps : sequence of TrackedSweep
    camera : CameraIntrinsics
    anchors : (K, 3) array
        Glasses anchor points in the head model's frame, mm.
    landmarks : sequence of sequences, optional
        Landmarks to use instead of each sweep's own (e.g. annotated with noise).
    settle : callable, optional
        Called after each estimate, outside its timing (e.g. to wait for a
        background refinement, so that the results do not depend on timing).
    clock : callable
        Seconds now, read before and after each estimate (the wall clock by default).

    Returns
    -------
    results : dict
        :class:`SweepResult` per sweep name, and ``"all"`` over all frames.
    timing : dict
        ``ms_mean``, ``ms_median``, ``ms_p99`` per estimate, and ``calls``.
    """
    results: dict[str, SweepResult] = {}
    parts: list[_Frames] = []
    times: list[float] = []
    for k, sweep in enumerate(sweeps):
        marks = landmarks[k] if landmarks is not None else sweep.landmarks
        part = _run_sweep(estimate, sweep, marks, camera, anchors, times, settle, clock)
        results[sweep.spec.name] = part.result(sweep.spec.name)
        parts.append(part)
    total = _Frames(np.vstack([p.errors for p in parts]),
                    np.concatenate([p.anchor for p in parts]),
                    np.full(sum(len(p.errors) for p in parts), np.nan),
                    sum(p.unreliable for p in parts), sum(p.no_pose for p in parts),
                    sum((p.reasons or Counter() for p in parts), Counter()))
    results["all"] = total.result("all")
    ms = 1000.0 * np.array(times) if times else np.full(1, np.nan)
    timing = {"ms_mean": float(ms.mean()), "ms_median": float(np.median(ms)),
              "ms_p99": float(np.percentile(ms, 99)), "calls": float(len(times))}
    return results, timing
