"""Head pose at large yaw: the stack's estimators on rendered sweeps and a synth sequence.

Run (from the repository root, ``AAMTRACK_DATA`` set)::

    python -m bench pose-yaw [--tracker annotated,aam]
        [--tracker-fn module:function] [--sequence DIR] [--skip-sweeps] [--eos]
        [--noise 0.02] [--ablations] [--variants a,b]

The synthetic head (``aamcore.synth``) is rendered through four sweeps at
640x480 (``aamcore.evaluation.pose_sweeps.DEFAULT_SWEEPS``): yaw to +-60 degrees (120
frames), pitch and roll to +-40 (90 frames each), distance 40-120 cm (90);
``--sequence DIR`` adds a folder written by ``aamtrack synth --max-angle 60``
(its video is mp4v-compressed; there pitch and roll go to +-60 too). Landmarks
come from *trackers*:

- ``annotated``: the landmarks as an annotator marks them (inner points exact,
  jaw points on the outline seen, by landmark marching on the head mesh) plus
  Gaussian noise of ``--noise`` times the outer-eye-corner distance (twice
  that on the jaw): a stand-in for an accurate tracker trained on large poses;
- ``aam``: the stack's tracker (default model, algorithm and failure test,
  Haar re-detection) on the rendered frames, cached under ``<cache>/pose_sweeps``;
- any ``track(frames) -> landmarks`` function named by ``--tracker-fn``.

Variants, each through :class:`aamcore.pose.estimator.HeadPoseEstimator` as
the stack runs it: ``posit`` (the thesis's POSIT, all 68 points),
``posit-nojaw`` (POSIT without the jaw, the stack's estimator before
ContourPose), ``contour`` (the default) and ``contour+calib`` (fed in sweep
order; each background refinement is waited for outside the timing, so the
numbers do not depend on timing); ``--eos`` adds the eos-py shape fit
(``bench/eos_pose.py``), ``--ablations`` ContourPose without visibility,
without Huber weights and without the outline.

One table per data set and tracker: per variant and sweep the frames with a
reliable pose and the flagged ones, the error sd (mean) of roll, pitch, yaw
(deg) and distance (cm), the mean reprojection error of the glasses' anchor
points (lens centres, bridge, hinges) in pixels, and ms per estimate. Then a
bad-input section, and the targets: error sd <= 1.5 deg in roll, pitch and
yaw and <= 1.0 cm in distance, over all sweeps and on the yaw sweep; a wrong
pose (> 10 deg off) never called reliable on bad input.
"""

from __future__ import annotations

import argparse
import importlib
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from aamcore import defaults
from aamcore.ar.glasses_mesh import mean_head_glasses
from aamcore.evaluation.pose_scores import SweepResult, evaluate_estimator
from aamcore.evaluation.pose_sweeps import (
    DEFAULT_SWEEPS,
    TrackedSweep,
    sequence_sweeps,
    tracked_sweeps,
)
from aamcore.pose.calibrate import OnlineCalibration
from aamcore.pose.errors import PoseError
from aamcore.pose.estimator import Cameras, HeadPoseEstimator
from aamcore.pose.head_model import openface68
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.robust import ContourPose
from aamcore.pose.rotation import rotation_angle_deg, rotation_from_rpy
from aamcore.synth.head import synth_head
from aamcore.synth.sequence import PoseTruth, annotated_landmarks
from bench import options
from bench.targets import Target

SD_DEG = Target("roll, pitch and yaw error sd, each estimator, tracker and scope", "<=", 1.5,
                "deg")
SD_CM = Target("distance error sd, each estimator, tracker and scope", "<=", 1.0, "cm")
WRONG_DEG = 10.0
BAD_INPUT = Target(f"never a pose > {WRONG_DEG:g} deg off called reliable on bad input", "==",
                   True)
TARGETS = (SD_DEG, SD_CM, BAD_INPUT)
PARAMS = ("roll", "pitch", "yaw", "distance_cm")
Estimate = Callable[[np.ndarray, CameraIntrinsics], Any]


class Variant:
    """One estimator as the bench runs it: ``estimate(landmarks, camera)`` and ``settle()``.

    Stack variants go through :class:`HeadPoseEstimator` with a camera of the
    same field of view, so they run exactly as the pose service does.
    """

    def __init__(self, name: str, estimate: Estimate, settle: Callable[[], object] | None = None
                 ) -> None:
        self.name, self.estimate, self.settle = name, estimate, settle
        self.calibration: OnlineCalibration | None = None

    @classmethod
    def stack(cls, name: str, camera: CameraIntrinsics, **kwargs: Any) -> Variant:
        fov = math.degrees(2.0 * math.atan(camera.width / (2.0 * camera.K[0, 0])))
        est = HeadPoseEstimator(Cameras(fov), **kwargs)
        if not np.allclose(est.cameras.at(camera.width, camera.height).K, camera.K):
            raise SystemExit(f"{name}: the data's camera is not one of a field of view")
        v = cls(name, lambda lm, cam: est.estimate(lm, cam.width, cam.height).estimate,
                est.wait if est.calibration is not None else None)
        v.calibration = est.calibration
        return v


def variants(camera: CameraIntrinsics, args: argparse.Namespace) -> list[Variant]:
    """Fresh estimators (contour+calib keeps state: one set per tracker and data set)."""
    out = [
        Variant.stack("posit", camera, model=openface68(), method="posit"),
        Variant.stack("posit-nojaw", camera, method="posit"),
        Variant.stack("contour", camera, method="contour"),
        Variant.stack("contour+calib", camera, method="contour+calib"),
    ]
    if args.ablations:
        for name, kwargs in (("contour-novis", {"visibility": False}),
                             ("contour-nohuber", {"huber": None}),
                             ("rigid-nojaw", {"outline": None})):
            out.append(Variant(name, ContourPose(**kwargs).estimate))
    if args.eos:
        from bench.eos_pose import EosPose  # bench/eos_pose.py

        try:
            out.append(Variant("eos", EosPose().estimate))
        except PoseError as exc:  # eos-py is not installed
            print(f"eos left out: {exc}")
    if args.variants:
        out = [v for v in out if v.name in args.variants.split(",")]
    return out


def aam_tracker(args: argparse.Namespace
                ) -> tuple[Callable[[Any], list[np.ndarray | None]], str]:
    """The stack's tracker as ``track(frames) -> landmarks``, and its cache name."""
    from aamcore.detection.haar import HaarFaceDetector
    from aamcore.evaluation.tracking import track_frames
    from aamcore.fitting.fitter import Fitter
    from aamcore.fitting.model import FittingModel
    from aamcore.fitting.tracker import Tracker

    path = options.model_path(args)
    fitter = Fitter(FittingModel.load(path), defaults.ALGORITHM,
                    failure_test=defaults.FAILURE_TEST)
    tracker = Tracker(fitter, HaarFaceDetector())
    name = f"aam-{defaults.ALGORITHM}-{defaults.FAILURE_TEST}-{path.stem}"
    return (lambda frames: track_frames(frames, tracker)[0]), name


def annotated_noisy(sweeps: list[TrackedSweep], camera: CameraIntrinsics, noise: float,
                    seed: int) -> list[list[np.ndarray | None]]:
    """Annotated landmarks with noise ``noise`` x eye-corner distance (x2 on the jaw)."""
    rng = np.random.default_rng(seed)
    head = synth_head()
    out = []
    for sweep in sweeps:
        marks: list[np.ndarray | None] = []
        for uv in annotated_landmarks(head, sweep.poses, camera):
            sd = np.full((68, 1), noise * float(np.linalg.norm(uv[36] - uv[45])))
            sd[:17] *= 2.0
            marks.append(uv + rng.standard_normal(uv.shape) * sd)
        out.append(marks)
    return out


def _cell(e: dict[str, float]) -> str:
    return f"{e['std']:6.2f} ({e['mean']:+5.2f})"


def _covered(r: SweepResult) -> str:
    """The range of the swept parameter with reliable poses, e.g. ``-42..+38``."""
    lo, hi = r.covered
    return f"{lo:+.0f}..{hi:+.0f}" if np.isfinite(lo) else "-"


def print_table(title: str, rows: list[tuple[str, dict[str, SweepResult], dict[str, float]]]
                ) -> None:
    """One table: per variant a row per sweep, then all sweeps."""
    print(f"\n{title}")
    heads = ("roll", "pitch", "yaw", "dist cm")
    print(f"{'variant':<16}{'sweep':<14}{'ok/frames':>10}{'flag':>5}{'covered':>10}"
          + "".join(f"{h + ' sd (mean)':>18}" for h in heads) + f"{'glasses px':>11}{'ms':>8}")
    for name, results, timing in rows:
        order = [k for k in results if k != "all"] + ["all"]
        for k in order:
            r = results[k]
            ms = f"{timing['ms_median']:8.2f}" if k == "all" else ""
            covered = _covered(r) if k != "all" else ""
            print(f"{name if k == order[0] else '':<16}{k:<14}{r.estimated:>5}/{r.frames:<4}"
                  f"{r.unreliable:>5}{covered:>10}"
                  + "".join(f"{_cell(r.errors[p]):>18}" for p in PARAMS)
                  + f"{r.anchor_px_mean:>11.2f}{ms}")
        reasons = sorted(results["all"].reasons.items(), key=lambda item: -item[1])
        if reasons:
            print(f"{'':<16}no pose / flagged: " + "; ".join(f"{n} x {k}" for k, n in reasons))


def verdicts(label: str, results: dict[str, SweepResult], scopes: list[str]) -> None:
    """Check the sd targets over ``scopes``."""
    for scope in scopes:
        e = results[scope].errors
        for p in PARAMS:
            where = "" if scope == "all" else f" over {_covered(results[scope])}"
            (SD_CM if p == "distance_cm" else SD_DEG).check(
                float(e[p]["std"]), f"{label} {scope} {p}: mean {e[p]['mean']:+.2f}, max "
                f"{e[p]['max_abs']:.1f}, {results[scope].estimated}/{results[scope].frames} "
                f"frames{where}")


def bad_inputs(camera: CameraIntrinsics, seed: int) -> list[tuple[str, np.ndarray, PoseTruth]]:
    """Hard cases: (name, landmarks (68, 2), true pose)."""
    head = synth_head()
    rng = np.random.default_rng(seed)

    def seen(yaw: float, T: tuple[float, float, float] = (0.0, 0.0, 600.0)
             ) -> tuple[np.ndarray, PoseTruth]:
        pose = PoseTruth(rotation_from_rpy(0.0, 0.0, yaw), np.array(T))
        return annotated_landmarks(head, [pose], camera)[0], pose

    cases = [(f"profile yaw {yaw:.0f}", *seen(yaw)) for yaw in (70.0, 80.0, 90.0)]
    uv, pose = seen(20.0)
    mirrored = uv.copy()
    mirrored[:, 0] = 2.0 * camera.K[0, 2] - mirrored[:, 0]  # a reflection, labels kept
    cases.append(("mirror image (x flipped, labels kept)", mirrored, pose))
    cases += [(f"scrambled points (seed {k})", uv[np.random.default_rng(k).permutation(68)],
               pose) for k in range(3)]
    cases.append(("half the face outside the frame", *seen(20.0, (350.0, 0.0, 600.0))))
    cases.append(("face far outside the frame", *seen(20.0, (900.0, 0.0, 600.0))))
    for what, rows in (("eyes and nose NaN", slice(27, 48)), ("all points NaN", slice(0, 68))):
        gaps = uv.copy()
        gaps[rows] = np.nan
        cases.append((what, gaps, pose))
    cases.append(("25 px noise", uv + rng.normal(0.0, 25.0, uv.shape), pose))
    return cases


def run_bad_inputs(chosen: list[Variant], camera: CameraIntrinsics, seed: int) -> None:
    """Each variant on each hard case; missed when a pose off by > 10 deg is called
    reliable."""
    print("\nbad input (a reliable answer's angle error, else the reason)")
    failed: dict[str, str] = {}
    for case, uv, truth in bad_inputs(camera, seed):
        print(f"  {case}")
        for v in chosen:
            try:
                e = v.estimate(uv, camera)
                err = rotation_angle_deg(e.R, truth.R)
                verdict = (f"reliable, off by {err:.1f} deg" if e.reliable
                           else f"unreliable: {e.reason[:80]}")
                if e.reliable and err > WRONG_DEG:
                    failed.setdefault(v.name, f"calls a pose {err:.0f} deg off reliable ({case})")
            except PoseError as exc:
                verdict = f"no pose: {str(exc)[:80]}"
            except Exception as exc:  # noqa: BLE001 - a crash is a result here
                verdict = f"CRASH {type(exc).__name__}: {exc}"
                failed.setdefault(v.name, f"crashes on {case}")
            print(f"    {v.name:<16}{verdict}")
    for v in chosen:
        BAD_INPUT.check(v.name not in failed, f"{v.name} {failed.get(v.name, '')}".strip())


def live_timing(sweeps: list[TrackedSweep], marks: list[list[np.ndarray | None]] | None,
                camera: CameraIntrinsics, anchors: np.ndarray) -> str:
    """contour+calib as the stack runs it, refinements not waited for: time per estimate."""
    v = Variant.stack("contour+calib", camera, method="contour+calib")
    _, timing = evaluate_estimator(v.estimate, sweeps, camera, anchors, marks)
    if v.settle is not None:
        v.settle()
    return (f"INFO: contour+calib with the refinement running beside the estimates (not "
            f"waited for): {timing['ms_median']:.2f} ms median, p99 {timing['ms_p99']:.2f} ms "
            f"per estimate, {v.calibration.refinements if v.calibration else 0} refinements")


def trackers(args: argparse.Namespace) -> list[tuple[str, Callable[..., Any] | None, str]]:
    """(label, track function or None for annotated, cache name) of each tracker asked for."""
    out: list[tuple[str, Callable[..., Any] | None, str]] = []
    for name in args.tracker.split(","):
        if name == "annotated":
            out.append(("annotated", None, "none"))
        elif name == "aam":
            track, cache_name = aam_tracker(args)
            out.append(("aam", track, cache_name))
        elif name:
            raise SystemExit(f"unknown tracker {name!r}: annotated or aam")
    if args.tracker_fn:
        module, _, fn = args.tracker_fn.partition(":")
        out.append((args.tracker_fn, getattr(importlib.import_module(module), fn),
                    args.tracker_fn))
    return out


def data_sets(args: argparse.Namespace, track: Callable[..., Any] | None, cache_name: str,
              camera: CameraIntrinsics) -> list[tuple[str, list[TrackedSweep], CameraIntrinsics]]:
    """(name, sweeps, camera) of the rendered sweeps and of ``--sequence``."""
    out = []
    if not args.skip_sweeps:
        out.append(("rendered sweeps", tracked_sweeps(
            track, cache_name, camera, DEFAULT_SWEEPS, use_cache=not args.no_cache,
            log=lambda m: print(f"  {m}", flush=True)), camera))
    if args.sequence is not None:
        started = time.perf_counter()
        sweeps, cam = sequence_sweeps(args.sequence, track, cache_name,
                                      use_cache=not args.no_cache)
        if track is not None:
            print(f"  {args.sequence}: tracked with {cache_name} (or read from the cache) in "
                  f"{time.perf_counter() - started:.0f} s", flush=True)
        out.append((f"aamtrack synth sequence {args.sequence}", sweeps, cam))
    return out


def tracker_note(sweeps: list[TrackedSweep], track: Callable[..., Any] | None) -> str:
    """How many frames the tracker found a face in, and its landmark error."""
    n = sum(len(s.poses) for s in sweeps)
    if track is None:
        return f"{n}/{n} frames"
    errs = [float(np.linalg.norm(lm - ex, axis=1).mean()) for s in sweeps
            for lm, ex in zip(s.landmarks, s.exact, strict=True) if lm is not None]
    return (f"{len(errs)}/{n} frames with landmarks, mean error "
            f"{np.mean(errs) if errs else float('nan'):.2f} px from the fixed landmark points")


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__, model=True)
    parser.add_argument("--tracker", default="annotated,aam",
                        help="comma-separated: annotated, aam (default both)")
    parser.add_argument("--tracker-fn", help="module:function, a track(frames) -> landmarks")
    parser.add_argument("--noise", type=float, default=0.02,
                        help="annotated tracker noise sd, fraction of the eye-corner distance")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--eos", action="store_true", help="also the eos-py shape fit (slow)")
    parser.add_argument("--ablations", action="store_true", help="also ContourPose ablations")
    parser.add_argument("--variants", help="comma-separated subset of the variants")
    parser.add_argument("--sequence", type=Path, help="a folder written by 'aamtrack synth'")
    parser.add_argument("--skip-sweeps", action="store_true", help="only the --sequence")
    parser.add_argument("--no-cache", action="store_true", help="re-track even if cached")
    args = options.parse(parser, argv)
    camera = CameraIntrinsics.from_fov(640, 480, 60.0)
    anchors = mean_head_glasses().anchor_points()
    lines: list[str] = []
    for label, track, cache_name in trackers(args):
        for data_name, sweeps, cam in data_sets(args, track, cache_name, camera):
            marks = annotated_noisy(sweeps, cam, args.noise, args.seed) if track is None else None
            tracked = (f"annotated + {args.noise:g} x eye-distance noise" if track is None
                       else f"tracker {label}")
            rows = []
            for v in variants(cam, args):
                results, timing = evaluate_estimator(v.estimate, sweeps, cam, anchors, marks,
                                                     v.settle)
                rows.append((v.name, results, timing))
                yaw = [s.spec.name for s in sweeps if s.spec.parameter == "yaw"]
                verdicts(f"{v.name} [{label}, {data_name}]", results, ["all", *yaw])
                lines.append(f"INFO: {v.name} [{label}, {data_name}] {timing['ms_median']:.2f} "
                             f"ms median, p99 {timing['ms_p99']:.2f} ms per estimate")
            print_table(f"== {data_name}, {tracked}: {tracker_note(sweeps, track)}", rows)
            lines.append(live_timing(sweeps, marks, cam, anchors))
    run_bad_inputs(variants(camera, args), camera, args.seed)
    print("\n(error sd (mean) in deg, distance in cm; glasses: mean anchor px; ms: median "
          "per estimate)\n")
    for line in lines:
        print(line)
    return 0

