"""Smoothing bench: jitter, accuracy and lag of the One Euro smoothing of landmarks and pose.

Run: ``python -m bench smoothing``

The same tracker (:class:`aamcore.tracker.FaceTracker`, the default model)
with smoothing off and on, on:

1. ``videos/single_face.mp4`` (a person talking to a webcam);
2. a **still** face: a held-out LFPW photo that does not move, with sensor
   noise and brightness flicker, exact landmarks known;
3. **moving** faces: held-out LFPW photos moved smoothly (translation,
   rotation to +-30 deg, scale 0.7-1.4, motion blur), exact landmarks known.

Per sequence: jitter (mean frame-to-frame landmark movement, px), landmark
NME against the truth (mean; outer-eye-corner distance), yaw jitter (deg) and
the lag the smoothing adds (frames by which the smoothed face centre trails
the unsmoothed one along its motion, least squares, fractions of a frame).
Targets: jitter -50 % or better on the still face, NME within +5 % of
unsmoothed on every sequence, lag reported.
"""

from __future__ import annotations

import numpy as np

from aamcore.config import data_root, resolve_dataset
from aamcore.evaluation.metrics import nme
from aamcore.io import load_annotated_folder
from aamcore.io.landmarks import scheme_for
from aamcore.io.splits import split
from aamcore.io.video import video_frames
from aamcore.synth.motion import MotionSpec, generate
from aamcore.tracker import FaceTracker
from bench import options
from bench.targets import Target

JITTER = Target("jitter on the still face, smoothed against unsmoothed", "<=", -50.0, "%")
NME = Target("NME, smoothed against unsmoothed", "<=", 5.0, "%")
TARGETS = (JITTER, NME)


def run(tracker: FaceTracker, frames: list[np.ndarray], fps: float = 30.0) -> list:
    tracker.reset()
    tracker.frames = 0
    return [tracker.process(frame, k / fps) for k, frame in enumerate(frames)]


def jitter(results: list) -> float:
    """Mean frame-to-frame landmark movement (px) over consecutive good frames."""
    steps = [np.linalg.norm(b.landmarks - a.landmarks, axis=1).mean()
             for a, b in zip(results, results[1:], strict=False) if a.success and b.success]
    return float(np.mean(steps)) if steps else float("nan")


def yaw_jitter(results: list) -> float:
    steps = [abs(b.yaw_deg - a.yaw_deg) for a, b in zip(results, results[1:], strict=False)
             if a.success and b.success and np.isfinite(a.yaw_deg) and np.isfinite(b.yaw_deg)]
    return float(np.mean(steps)) if steps else float("nan")


def mean_nme(results: list, truth: np.ndarray | None) -> float:
    if truth is None:
        return float("nan")
    scheme = scheme_for(truth.shape[1])
    errors = [nme(r.landmarks, t, scheme) for r, t in zip(results, truth, strict=True)
              if r.success]
    return float(np.mean(errors)) if errors else float("nan")


def lag_frames(raw: list, smooth: list) -> float:
    """Frames by which the smoothed face centre trails the raw one: the least-squares ``L``
    in ``smooth(k) ~ raw(k) - L * (raw(k) - raw(k - 1))`` over consecutive good frames."""
    ok = [i for i in range(1, len(raw)) if raw[i].success and smooth[i].success
          and raw[i - 1].success]
    if len(ok) < 10:
        return float("nan")
    centre = [r.landmarks.mean(axis=0) for r in raw]
    behind = np.array([centre[i] - smooth[i].landmarks.mean(axis=0) for i in ok])
    step = np.array([centre[i] - centre[i - 1] for i in ok])
    moved = float(np.sum(step * step))
    return float(np.sum(behind * step) / moved) if moved > 0 else float("nan")


def sequences(n_moving: int) -> list[tuple[str, list[np.ndarray], np.ndarray | None]]:
    out: list[tuple[str, list[np.ndarray], np.ndarray | None]] = [
        ("single_face.mp4", video_frames(data_root() / "videos" / "single_face.mp4"), None)]
    data = load_annotated_folder(resolve_dataset("lfpw"))
    _, test = split(data.samples, "lfpw")
    still = generate(test[0].load_image(), test[0].points,
                     MotionSpec(frames=90, speed=0.0, max_angle_deg=0.0, scales=(1.0, 1.0),
                                blur=False, brightness=8.0, noise=4.0, seed=3))
    out.append(("still face (LFPW held out)", still.frames, still.landmarks))
    for k in range(n_moving):
        sample = test[1 + k]
        seq = generate(sample.load_image(), sample.points, MotionSpec(frames=150, seed=10 + k))
        out.append((f"moving face {k + 1}", seq.frames, seq.landmarks))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__)
    parser.add_argument("--moving", type=int, default=3, help="moving sequences")
    args = options.parse(parser, argv)
    raw_tracker, smooth_tracker = (FaceTracker(classifier=False,
                                               landmark_smoothing=False, pose_smoothing=False),
                                     FaceTracker(classifier=False))
    print(f"{'sequence':<28}{'jitter px':>10}{'smoothed':>9}{'change':>8}{'NME':>8}"
          f"{'smoothed':>9}{'change':>8}{'yaw jit':>8}{'smoothed':>9}{'lag fr':>7}")
    ok = True
    for name, frames, truth in sequences(args.moving):
        raw, smooth = run(raw_tracker, frames), run(smooth_tracker, frames)
        j0, j1 = jitter(raw), jitter(smooth)
        e0, e1 = mean_nme(raw, truth), mean_nme(smooth, truth)
        lag = lag_frames(raw, smooth)
        print(f"{name:<28}{j0:>10.3f}{j1:>9.3f}{(j1 / j0 - 1):>8.0%}{e0:>8.4f}{e1:>9.4f}"
              f"{(e1 / e0 - 1) if truth is not None else float('nan'):>8.1%}"
              f"{yaw_jitter(raw):>8.2f}{yaw_jitter(smooth):>9.2f}{lag:>7.2f}")
        if name.startswith("still"):
            ok &= JITTER.check(100 * (j1 / j0 - 1), name)
        if truth is not None:
            ok &= NME.check(100 * (e1 / e0 - 1), name)
    return 0 if ok else 1

