"""Occlusion bench: per-landmark occlusion flags against the generated occluder's ground truth.

Run: ``OMP_NUM_THREADS=1 .venv/bin/python bench/bench_occlusion.py [--model FILE]
[--per-set 4] [--frames 150] [--regenerate]``

The tracker runs as the library runs it (:class:`aamcore.tracker.FaceTracker`,
the default profile: local-binary landmarks, the AAM's appearance and its
occlusion flags on every good fit; no smoothing) on the tracking bench's
sequences (``bench_tracking.py``: held-out photos of LFPW, HELEN and AFW
moved, lit and blurred; every second one with a skin-coloured hand crossing
the face in frames 40 % to 60 %). The ground truth of each frame says, per
landmark, the share of its part of the face (a disc of 0.08 face widths
around it, :data:`aamcore.synth.motion.PART_RADIUS`) that the hand covers.

Scored on the frames with a good fit (a failed fit or no face has no flags;
the occluded frames without one are counted apart): a landmark is
**covered** when at least half its part of the face is under the hand and
**visible** when none of it is; the landmarks in between (the hand's edge)
are counted, not scored. Reported: the share of covered landmarks flagged,
of visible ones flagged in the sequences with the hand and in those without
it, and of the landmarks flagged on ``videos/single_face.mp4`` (a talking
face, nothing covering it).

Targets: >= 90 % of the covered landmarks flagged, <= 5 % of the visible ones.

Also the expression gate's "face covered" rule per frame
(:attr:`aamcore.expression.spec.QualityLimits.max_covered`: the share of the inner
landmarks flagged): of the frames where the hand covers at least
:data:`FACE_COVERED` of the inner landmarks, and of those without the hand (and of
``single_face.mp4``), the share the rule refuses, for the deployed limit and others.
"""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

from aamcore.config import data_root  # noqa: E402
from aamcore.fitting.model import FittingModel  # noqa: E402
from aamcore.fitting.training.prepare import default_model_path  # noqa: E402
from aamcore.io.video import video_frames  # noqa: E402
from aamcore.tracker import FaceTracker  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from tracking_clips import generated_clips  # noqa: E402

TARGET_COVERED, TARGET_VISIBLE = 0.90, 0.05
COVERED, VISIBLE = 0.5, 0.0
"""A landmark is covered at or above this share of its part of the face, visible at none."""
INNER = slice(17, 68)
FACE_COVERED = 0.2
"""A frame's face is covered when the hand covers at least this share of its inner landmarks."""
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
    groups: dict[str, list[int]] = field(default_factory=lambda: {g: [0, 0] for g in GROUPS})
    frames: list[tuple[float, bool]] = field(default_factory=list)
    """(share of the inner landmarks flagged, face covered) of the frames judged."""

    def add(self, other: Tally) -> None:
        self.frames += other.frames
        for name in ("covered", "covered_flagged", "visible", "visible_flagged", "clean",
                     "clean_flagged", "partly", "occluded_frames", "occluded_without_fit"):
            setattr(self, name, getattr(self, name) + getattr(other, name))
        for g, (n, f) in other.groups.items():
            self.groups[g][0] += n
            self.groups[g][1] += f


def share(part: int, whole: int) -> str:
    return f"{part / whole:6.1%}" if whole else "     -"


def score(tracker: FaceTracker, frames: list[np.ndarray], covered: np.ndarray,
          with_hand: bool) -> Tally:
    """Track ``frames`` from a fresh start and count the flags against ``covered`` (F, N)."""
    tracker.reset()
    tracker.frames = 0
    t = Tally()
    for k, frame in enumerate(frames):
        result = tracker.process(frame, k / 30.0)
        shares = covered[k]
        hand = bool(shares.max() > 0)
        t.occluded_frames += hand
        if result.occluded is None:
            t.occluded_without_fit += hand
            continue
        flags = result.occluded
        cov, vis = shares >= COVERED, shares <= VISIBLE
        inner_covered = float(np.mean(cov[INNER]))
        if not hand or inner_covered >= FACE_COVERED:
            t.frames.append((float(np.mean(flags[INNER])), hand))
        t.partly += int((~cov & ~vis).sum())
        if not with_hand:
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


def row(name: str, t: Tally) -> str:
    return (f"{name:<26}{t.covered:>8}{share(t.covered_flagged, t.covered):>9}"
            f"{t.visible:>8}{share(t.visible_flagged, t.visible):>9}{t.clean:>8}"
            f"{share(t.clean_flagged, t.clean):>9}{t.partly:>7}"
            f"{t.occluded_frames:>6}{t.occluded_without_fit:>8}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", type=Path, help="fitting model (default: the default one)")
    parser.add_argument("--per-set", type=int, default=4, help="sequences per set")
    parser.add_argument("--frames", type=int, default=150, help="frames per sequence")
    parser.add_argument("--regenerate", action="store_true", help="remake the sequences")
    args = parser.parse_args(argv)
    path = args.model or default_model_path()
    model = FittingModel.load(path)
    if model.occlusion is None:
        sys.exit(f"{path}: this model has no occlusion part: retrain it")
    tracker = FaceTracker(model=model, classifier=False, smoothing=False)
    report = model.occlusion.report
    print(f"model {Path(path).name}: occlusion test trained on {report.get('faces')} faces, "
          f"{report.get('views')} views; on them {report.get('training_covered_flagged', 0):.1%}"
          f" of covered landmarks flagged, {report.get('training_visible_flagged', 0):.1%} of "
          f"visible ones")
    print(f"\n{'sequence':<26}{'covered':>8}{'flagged':>9}{'visible':>8}{'flagged':>9}"
          f"{'clean':>8}{'flagged':>9}{'partly':>7}{'hand':>6}{'no fit':>8}")
    total, by_set = Tally(), {}
    with threadpool_limits(1):
        for clip in generated_clips(model, args.per_set, args.frames, args.regenerate):
            assert clip.truth is not None
            with_hand = clip.truth.spec is not None and clip.truth.spec.occluder is not None
            t = score(tracker, video_frames(clip.video), clip.truth.covered, with_hand)
            print(row(clip.name, t))
            by_set.setdefault(clip.set_name, Tally()).add(t)
            total.add(t)
        print()
        for name, t in by_set.items():
            print(row(f"{name} (all)", t))
        print(row("all", total))
        video = video_frames(data_root() / "videos" / "single_face.mp4")
        real = score(tracker, video, np.zeros((len(video), 68)), False)
    print("\ncovered landmarks flagged by part: " + ", ".join(
        f"{g} {share(f, n).strip()} of {n}" for g, (n, f) in total.groups.items()))
    print(f"single_face.mp4 (nothing covers the face): {share(real.clean_flagged, real.clean)}"
          f" of the landmarks of {real.clean // 68} good fits flagged")
    covered = total.covered_flagged / max(total.covered, 1)
    visible = total.visible_flagged / max(total.visible, 1)
    print(f"\n{'PASS' if covered >= TARGET_COVERED else 'FAIL'}: {covered:.1%} of the covered "
          f"landmarks flagged (target >= {TARGET_COVERED:.0%})")
    clean = share(total.clean_flagged, total.clean).strip()
    print(f"{'PASS' if visible <= TARGET_VISIBLE else 'FAIL'}: {visible:.1%} of the visible "
          f"landmarks flagged (target <= {TARGET_VISIBLE:.0%}; {clean} in the sequences "
          "without the hand)")
    print(f"occluded frames without a good fit (no flags): {total.occluded_without_fit} of "
          f"{total.occluded_frames}")
    print(f"\nexpression gate 'face covered' (share of inner landmarks flagged > limit), frames "
          f"refused: | limit | covered faces (hand over >= {FACE_COVERED:.0%} of the inner "
          "landmarks) | faces without the hand | single_face.mp4 |")
    shares = np.array([f for f, _ in total.frames])
    covered_face = np.array([c for _, c in total.frames], bool)
    clean_video = np.array([f for f, _ in real.frames])
    for limit in LIMITS:
        cells = [f"{share(int((v > limit).sum()), len(v)).strip()} of {len(v)}"
                 for v in (shares[covered_face], shares[~covered_face], clean_video)]
        print(f"| {limit:g} | " + " | ".join(cells) + " |")
    return 0 if covered >= TARGET_COVERED and visible <= TARGET_VISIBLE else 1


if __name__ == "__main__":
    raise SystemExit(main())
