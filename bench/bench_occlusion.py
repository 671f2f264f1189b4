"""Occlusion bench: per-landmark occlusion flags against the generated occluder's ground truth.

Run: ``OMP_NUM_THREADS=1 python -m bench occlusion [--model FILE]
[--per-set 4] [--frames 150] [--regenerate]``

The tracker runs as the library runs it (:class:`aamcore.tracker.FaceTracker`,
the default profile: local-binary landmarks, the AAM's appearance and its
occlusion flags on every good fit; no smoothing) on the tracking bench's
sequences (``bench_tracking.py``: held-out photos of LFPW, HELEN and AFW, faces
the fitting model and its occlusion test never saw, moved, lit and blurred),
every second one with an occluder in frames 40 % to 60 %, its kind taken in
turn from :data:`KINDS`: the skin-coloured hand crossing the face, a hand
resting on it (skin tones from light to dark), an object (flat, shaded or
patterned), a lock of hair, sunglasses, the frame's edge (the face slides a
quarter to a half out of the frame) (:mod:`aamcore.synth.motion`,
:mod:`aamcore.fitting.occluders`). The ground truth of each frame
says, per landmark, the share of its part of the face (a disc of 0.08 face
widths around it) that the occluder hides (beyond the frame's edge counts as
hidden, but for the crossing hand).

Scored on the frames with a good fit (a failed fit or no face has no flags;
the occluded frames without one are counted apart): a landmark is
**covered** when at least half its part of the face is hidden and
**visible** when none of it is; the landmarks in between (the occluder's edge)
are counted, not scored. Reported: the share of covered landmarks flagged,
of visible ones flagged in the sequences with an occluder and in those without
one, per set and per kind, and of the landmarks flagged on
``videos/single_face.mp4`` (a talking face, nothing covering it).

Targets: >= 85 % of the covered landmarks flagged, <= 5 % of the visible ones,
<= 2 % of the landmarks of ``single_face.mp4``.

Beside them, the same occlusion test read at the annotated landmarks of every occluded
frame, fitted or not: what the flags would be with a perfect fit, so that a miss is told
apart as the fit's (it failed, or drifted) or the flags' own.

Also the head pose of every good fit (the default ``contour`` estimator) from all its
landmarks and from those it does not flag only (the flagged ones left out as non-finite),
each against the pose of the frame's annotated landmarks (``bench/occlusion_pose.py``):
whether leaving the flagged landmarks out of the pose pays, on the occluded frames and on
the others.

Also the expression gate's "face covered" rule per frame
(:attr:`aamcore.expression.spec.QualityLimits.max_covered`: the share of the inner
landmarks flagged): of the frames where the occluder hides at least
:data:`FACE_COVERED` of the inner landmarks, and of those without one (and of
``single_face.mp4``), the share the rule refuses, for the deployed limit and others.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np
from threadpoolctl import threadpool_limits

from aamcore.config import data_root
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.io.video import video_frames
from aamcore.synth.motion_files import video_path
from aamcore.tracker import FaceTracker
from bench import options
from bench.occlusion_pose import PoseErrors, PoseJudge
from bench.targets import Target
from bench.tracking_clips import (
    SETS,
    Clip,
    ensure_sequence,
    held_out_photos,
    motion_spec,
)

COVERED_FLAGGED = Target("covered landmarks flagged, generated sequences", ">=", 85.0, "%")
VISIBLE_FLAGGED = Target("visible landmarks flagged, generated sequences", "<=", 5.0, "%")
STILL_FLAGGED = Target("landmarks of good fits flagged on single_face.mp4 (nothing covers it)",
                       "<=", 2.0, "%")
TARGETS = (COVERED_FLAGGED, VISIBLE_FLAGGED, STILL_FLAGGED)
KINDS = ("crossing", "hand", "object", "hair", "glasses", "edge")
"""The occluders' kinds, in turn over the occluded sequences."""
COVERED, VISIBLE = 0.5, 0.0
"""A landmark is covered at or above this share of its part of the face, visible at none."""
INNER = slice(17, 68)
FACE_COVERED = 0.2
"""A frame's face is covered when the occluder hides at least this share of its inner landmarks."""
LIMITS = (0.1, 0.15, 0.2, 0.3)
GROUPS = {"jaw": range(0, 17), "brows": range(17, 27), "nose": range(27, 36),
          "eyes": range(36, 48), "mouth": range(48, 68)}


@dataclass
class Tally:
    """Counts over the frames of some sequences."""

    covered: int = 0
    covered_flagged: int = 0
    visible: int = 0
    visible_flagged: int = 0
    clean: int = 0
    clean_flagged: int = 0
    partly: int = 0
    occluded_frames: int = 0
    occluded_without_fit: int = 0
    at_truth: list[int] = field(default_factory=lambda: [0, 0, 0, 0])
    """The occlusion test at the annotated landmarks of every occluded frame: covered
    landmarks, of them flagged, visible landmarks, of them flagged."""
    groups: dict[str, list[int]] = field(default_factory=lambda: {g: [0, 0] for g in GROUPS})
    frames: list[tuple[float, bool]] = field(default_factory=list)
    """(share of the inner landmarks flagged, face covered) of the frames judged."""

    def add(self, other: Tally) -> None:
        self.frames += other.frames
        for name in ("covered", "covered_flagged", "visible", "visible_flagged", "clean",
                     "clean_flagged", "partly", "occluded_frames", "occluded_without_fit"):
            setattr(self, name, getattr(self, name) + getattr(other, name))
        self.at_truth = [a + b for a, b in zip(self.at_truth, other.at_truth, strict=True)]
        for g, (n, f) in other.groups.items():
            self.groups[g][0] += n
            self.groups[g][1] += f


def share(part: int, whole: int) -> str:
    return f"{part / whole:6.1%}" if whole else "     -"


def score(tracker: FaceTracker, frames: list[np.ndarray], covered: np.ndarray,
          occluded: bool, truth: np.ndarray | None = None, poses: PoseErrors | None = None,
          flags_at: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None) -> Tally:
    """Track ``frames`` from a fresh start and count the flags against ``covered`` (F, N);
    with the annotated landmarks ``truth`` (F, N, 2), the pose errors into ``poses``, and
    with ``flags_at(frame, landmarks)`` the flags at them on every occluded frame."""
    tracker.reset()
    tracker.frames = 0
    judge = PoseJudge() if truth is not None and poses is not None else None
    t = Tally()
    for k, frame in enumerate(frames):
        result = tracker.process(frame, k / 30.0)
        shares = covered[k]
        hand = bool(shares.max() > 0)
        t.occluded_frames += hand
        if hand and occluded and flags_at is not None and truth is not None:
            seen = flags_at(frame, truth[k])
            cov, vis = shares >= COVERED, shares <= VISIBLE
            t.at_truth = [a + int(b) for a, b in zip(t.at_truth, (
                cov.sum(), (seen & cov).sum(), vis.sum(), (seen & vis).sum()), strict=True)]
        if result.occluded is None:
            t.occluded_without_fit += hand
            if judge is not None:
                judge.reset()
            continue
        flags = result.occluded
        if judge is not None:
            judge.judge(result.landmarks, flags, truth[k], frame.shape[1::-1], hand, poses)
        cov, vis = shares >= COVERED, shares <= VISIBLE
        inner_covered = float(np.mean(cov[INNER]))
        if not hand or inner_covered >= FACE_COVERED:
            t.frames.append((float(np.mean(flags[INNER])), hand))
        t.partly += int((~cov & ~vis).sum())
        if not occluded:
            t.clean += len(flags)
            t.clean_flagged += int(flags.sum())
            continue
        t.covered += int(cov.sum())
        t.covered_flagged += int((flags & cov).sum())
        t.visible += int(vis.sum())
        t.visible_flagged += int((flags & vis).sum())
        for g, idx in GROUPS.items():
            sel = np.zeros(len(flags), bool)
            sel[list(idx)] = True
            t.groups[g][0] += int((cov & sel).sum())
            t.groups[g][1] += int((cov & sel & flags).sum())
    return t


def occluder_clips(model: FittingModel, per_set: int, frames: int, regenerate: bool
                   ) -> list[tuple[Clip, str]]:
    """The sequences of every set (``per_set`` each) with their occluder's kind ("" for
    none): every second one occluded, the kinds of :data:`KINDS` in turn."""
    clips, turn = [], 0
    for set_name in SETS:
        for k, sample in enumerate(held_out_photos(model, set_name, per_set)):
            spec, kind = motion_spec(set_name, k, frames), ""
            if spec.occluder is not None:
                kind = KINDS[turn % len(KINDS)]
                turn += 1
                spec = replace(spec, occluder_kind=kind)
            folder, truth = ensure_sequence(set_name, sample, spec, regenerate)
            name = f"{set_name} {Path(sample.image_path).stem}{f' +{kind}' if kind else ''}"
            clips.append((Clip(set_name, name, video_path(folder), truth), kind))
    return clips


def at_truth_line(total: Tally, by_kind: dict[str, Tally]) -> str:
    """The same occlusion test at the annotated landmarks of every occluded frame, fitted or
    not: what the flags would be with a perfect fit (the part of the misses the fit owes)."""
    def cell(t: Tally) -> str:
        n, f, v, vf = t.at_truth
        return f"{share(f, n).strip()} of {n} covered, {share(vf, v).strip()} visible"
    kinds = ", ".join(f"{k} {cell(t)}" for k, t in by_kind.items() if t.at_truth[0])
    return (f"at the annotated landmarks of every occluded frame (a perfect fit): flagged "
            f"{cell(total)}; by kind: {kinds}")


def row(name: str, t: Tally) -> str:
    return (f"{name:<26}{t.covered:>8}{share(t.covered_flagged, t.covered):>9}"
            f"{t.visible:>8}{share(t.visible_flagged, t.visible):>9}{t.clean:>8}"
            f"{share(t.clean_flagged, t.clean):>9}{t.partly:>7}"
            f"{t.occluded_frames:>6}{t.occluded_without_fit:>8}")


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__, model=True)
    parser.add_argument("--per-set", type=int, default=6, help="sequences per set")
    parser.add_argument("--frames", type=int, default=150, help="frames per sequence")
    parser.add_argument("--regenerate", action="store_true", help="remake the sequences")
    args = options.parse(parser, argv)
    path = options.model_path(args)
    model = FittingModel.load(path)
    if model.occlusion is None:
        sys.exit(f"{path}: this model has no occlusion part: retrain it")
    tracker = FaceTracker(model=model, classifier=False,
                          landmark_smoothing=False, pose_smoothing=False)
    sampler = Fitter(model).occlusion
    assert sampler is not None

    def flags_at(frame: np.ndarray, landmarks: np.ndarray) -> np.ndarray:
        return sampler.project_frame(frame, landmarks).occluded
    report = model.occlusion.report
    seen, unseen = report.get("training", {}), report.get("threshold_views", {})
    print(f"model {Path(path).name}: occlusion test trained on {report.get('faces')} faces, "
          f"{report.get('views')} views; covered landmarks flagged / visible ones flagged: "
          f"{seen.get('covered_flagged', 0):.1%} / {seen.get('visible_flagged', 0):.1%} on "
          f"its training views, {unseen.get('covered_flagged', 0):.1%} / "
          f"{unseen.get('visible_flagged', 0):.1%} on the faces kept apart for the threshold")
    print(f"\n{'sequence':<26}{'covered':>8}{'flagged':>9}{'visible':>8}{'flagged':>9}"
          f"{'clean':>8}{'flagged':>9}{'partly':>7}{'occl.':>6}{'no fit':>8}")
    total, by_set, by_kind = Tally(), {}, {}
    poses = PoseErrors()
    with threadpool_limits(1):
        for clip, kind in occluder_clips(model, args.per_set, args.frames, args.regenerate):
            assert clip.truth is not None
            t = score(tracker, video_frames(clip.video), clip.truth.covered, bool(kind),
                      clip.truth.landmarks, poses, flags_at)
            print(row(clip.name, t))
            by_set.setdefault(clip.set_name, Tally()).add(t)
            by_kind.setdefault(kind or "none", Tally()).add(t)
            total.add(t)
        print()
        for name, t in [*by_set.items(), *by_kind.items()]:
            print(row(f"{name} (all)", t))
        print(row("all", total))
        video = video_frames(data_root() / "videos" / "single_face.mp4")
        real = score(tracker, video, np.zeros((len(video), 68)), False)
    print("\ncovered landmarks flagged by part: " + ", ".join(
        f"{g} {share(f, n).strip()} of {n}" for g, (n, f) in total.groups.items()))
    still = real.clean_flagged / max(real.clean, 1)
    passed = STILL_FLAGGED.check(100 * still, f"{real.clean // 68} good fits")
    covered = total.covered_flagged / max(total.covered, 1)
    visible = total.visible_flagged / max(total.visible, 1)
    passed &= COVERED_FLAGGED.check(100 * covered)
    clean = share(total.clean_flagged, total.clean).strip()
    passed &= VISIBLE_FLAGGED.check(100 * visible, f"{clean} in the sequences without the hand")
    print(f"occluded frames without a good fit (no flags): {total.occluded_without_fit} of "
          f"{total.occluded_frames}")
    print(at_truth_line(total, by_kind))
    print("\nhead pose (contour) of the good fits against that of the annotated landmarks, "
          "degrees: | frames | from | poses | median | p90 | over 10 deg | no pose |")
    print("\n".join(poses.rows()))
    print(f"\nexpression gate 'face covered' (share of inner landmarks flagged > limit), frames "
          f"refused: | limit | covered faces (occluder over >= {FACE_COVERED:.0%} of the inner "
          "landmarks) | faces without an occluder | single_face.mp4 |")
    shares = np.array([f for f, _ in total.frames])
    covered_face = np.array([c for _, c in total.frames], bool)
    clean_video = np.array([f for f, _ in real.frames])
    for limit in LIMITS:
        cells = [f"{share(int((v > limit).sum()), len(v)).strip()} of {len(v)}"
                 for v in (shares[covered_face], shares[~covered_face], clean_video)]
        print(f"| {limit:g} | " + " | ".join(cells) + " |")
    return 0 if passed else 1

