"""Tracking bench: the stack's tracker on a real video and on generated videos with exact landmarks.

Run: ``OMP_NUM_THREADS=1 python -m bench tracking [--algorithm NAME]
[--model FILE] [--per-set 4] [--frames 150] [--nonrigid 2] [--schemes A B ...] [--parts-only]
[--no-refit] [--via-stack [N]] [--regenerate]``

The tracker runs through the library as the stack runs it
(:class:`aamcore.tracker.FaceTracker`: Haar detection, the fitter of
``--algorithm``, its refits from the mean face (``--no-refit``: none), re-detection on
the same frame when a fit fails; no smoothing), on one core, frame by frame, on:

1. ``videos/single_face.mp4`` (a person talking to a webcam; no ground truth:
   good fits, failed fits, frames without a face, re-detections, time);
2. sequences generated (:mod:`aamcore.synth.motion`) from **held-out** photos
   of LFPW, HELEN and AFW (the split of :mod:`aamcore.io.splits`, less any
   photo the model was trained on, told by content): smooth random motion
   (translation, in-plane rotation to +-30 deg, scale 0.7-1.4), brightness
   changes, motion blur; every second sequence of a set with a skin-coloured
   hand crossing the face (frames 40 % to 60 % of the sequence). Fixed seeds:
   the same sequences every run. They are written once as lossless videos
   with their ground truth (:mod:`aamcore.synth.motion_files`) under
   ``<cache>/sequences``, and read back from the files.

Per sequence: frames with a good fit (the fit passed the failure test),
overall and outside the occluder; failed fits; frames without a face;
re-detections (detector runs after the first frame); NME (mean point error /
outer-eye-corner distance of the truth, iBUG points 36 and 45) of the good
fits outside the occluder, mean and p95, and the share of them above 0.08;
frames to re-acquire the face after the occluder has left (0: the first frame
without it already has a good fit with NME < 0.08); time per frame, median and
p95. A summary row per set and overall pools the frames (re-acquisition: the
worst sequence).

Targets (overall, the rigid sequences): >= 98 % of the frames outside the occluder with a good fit;
mean NME <= 0.035 on them; re-acquisition within 5 frames on every sequence
with an occluder.

3. non-rigid sequences (``--nonrigid N`` per set, default 2): held-out photos whose face
   also changes shape, warped piecewise-affinely (:mod:`aamcore.synth.deform`) to an
   expression that changes over time (the mouth opening with the jaw and closing, a
   smile, the brows raised, blinks) blended toward the aligned shapes of two other
   held-out photos of the set, under smaller rigid motion (rotation to +-15 deg, scale
   0.85-1.2), with the same lighting, blur and occluder (every second sequence); the
   truth is the warped landmarks. Written and read back as the rigid ones are.

The schemes of ``--schemes`` are then compared per facial part (all, jaw, brows, nose,
eyes, mouth: NME mean/p95 of the good fits outside the occluder) on the rigid and the
non-rigid sequences, each frame timed through the :class:`~aamcore.fitting.tracker.Tracker`
(or the fitter) alone: ``track`` (tracking alone), ``refit:...`` (the tracker with
refits from the mean face, :class:`~aamcore.fitting.tracker.Refit`; ``refit:failed=1`` is
the default, :data:`~aamcore.fitting.tracker.DEFAULT_REFIT`), and the floors
``truth`` (every frame fitted from the mean face placed on that frame's true landmarks),
``previous`` (placed on the previous frame's fit), either ``+track`` (one tracking step
after). ``--parts-only`` skips the library table.

``--via-stack N`` also runs ``aamtrack run --video FILE --record FILE --pace
fast --no-ar --no-smooth`` with the same model and algorithm on the first N
generated videos, scores the recorded fits the same way and says on how many
frames the stack and the library agree.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2
import numpy as np
from threadpoolctl import threadpool_limits

from aamcore import defaults
from aamcore.config import REPO_ROOT, cache_dir, data_root, resolve_dataset
from aamcore.fitting.algorithm import ALGORITHMS
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.fitting.tracker import NEVER
from aamcore.io import load_annotated_folder
from aamcore.io.landmarks import LandmarkScheme
from aamcore.io.splits import set_name_of, split
from aamcore.io.video import video_frames
from aamcore.tracker import FaceResult, FaceTracker
from bench import options
from bench.targets import Target
from bench.tracking_clips import NONRIGID, Clip, generated_clips, nonrigid_clips
from bench.tracking_parts import HEADER as PARTS_HEADER
from bench.tracking_parts import Pool, parse_scheme, pool_row, run_scheme
from bench.tracking_scores import REACQUIRED_NME, Score, Track, pooled, score, track_of

REACQUIRE_FRAMES = 5
GOOD = Target("frames outside the occluder with a good fit, generated sequences", ">=", 98.0,
              "%")
NME = Target("mean NME of those good fits", "<=", 0.035)
REACQUIRED = Target(f"sequences re-acquired within {REACQUIRE_FRAMES} frames of the occluder "
                    "leaving", ">=", 100.0, "%")
TARGETS = (GOOD, NME, REACQUIRED)
SCHEMES = ("track", "refit:failed=1", "refit:every=6", "previous", "truth")
"""The schemes compared per part by default."""


def track(tracker: FaceTracker, frames: list[np.ndarray], fps: float) -> Track:
    """Track every frame from a fresh start, timing each."""
    tracker.reset()
    tracker.frames = 0
    before = tracker.fit.tracker.detections
    results: list[FaceResult] = []
    seconds = []
    for k, frame in enumerate(frames):
        t0 = time.perf_counter()
        results.append(tracker.process(frame, k / fps))
        seconds.append(time.perf_counter() - t0)
    return track_of(results, np.array(seconds), tracker.fit.tracker.detections - before)


HEADER = (f"{'sequence':<32}{'frames':>7}{'good':>7}{'good out':>9}{'failed':>7}{'no face':>8}"
          f"{'redet':>6}{'NME':>8}{'p95':>8}{'>0.08':>7}{'reacq':>7}{'ms med':>8}{'ms p95':>8}")


def worst_reacquire(values: list[int | None]) -> str:
    if not values:
        return "-"
    return "never" if None in values else str(max(v for v in values if v is not None))


def row(name: str, s: Score) -> str:
    """One table line."""
    def pct(a: int, b: int) -> str:
        return f"{a / b:.1%}" if b else "-"

    def num(x: float, fmt: str) -> str:
        return format(x, fmt) if np.isfinite(x) else "-"

    e = s.errors
    mean_e, p95_e = (float(e.mean()), float(np.percentile(e, 95))) if len(e) else (np.nan,) * 2
    wrong = pct(int(np.sum(e > REACQUIRED_NME)), len(e)) if len(e) else "-"
    ms = 1000 * s.seconds[np.isfinite(s.seconds)]
    med, p95 = (float(np.median(ms)), float(np.percentile(ms, 95))) if len(ms) else (np.nan,) * 2
    redet = str(s.redetections) if s.redetections >= 0 else "-"
    return (f"{name[:31]:<32}{s.frames:>7d}{pct(s.good, s.frames):>7}"
            f"{pct(s.good_outside, s.outside):>9}{s.failed:>7d}{s.no_face:>8d}"
            f"{redet:>6}{num(mean_e, '.4f'):>8}{num(p95_e, '.4f'):>8}{wrong:>7}"
            f"{worst_reacquire(s.reacquire):>7}{num(med, '.1f'):>8}{num(p95, '.1f'):>8}")


def verdicts(s: Score) -> bool:
    """Check the targets on the pooled generated sequences; whether all are met."""
    good = s.good_outside / s.outside if s.outside else 0.0
    mean_e = float(s.errors.mean()) if len(s.errors) else np.inf
    within = [r for r in s.reacquire if r is not None and r <= REACQUIRE_FRAMES]
    ok = GOOD.check(100 * good) & NME.check(mean_e)
    share = 100 * len(within) / len(s.reacquire) if s.reacquire else 0.0
    return REACQUIRED.check(share, f"{len(within)} of {len(s.reacquire)}, worst "
                                   f"{worst_reacquire(s.reacquire)}") and ok


def read_clip(path: Path) -> tuple[list[np.ndarray], float]:
    """Every frame of a video (BGR) and its frame rate (30 when it names none)."""
    capture = cv2.VideoCapture(str(path))
    fps = capture.get(cv2.CAP_PROP_FPS) or 30.0
    capture.release()
    return video_frames(path), fps if 1.0 <= fps <= 1000.0 else 30.0


def stack_track(clip: Clip, model_path: Path, algorithm: str, folder: Path
                ) -> tuple[Track, np.ndarray, float]:
    """Run ``aamtrack run`` on a clip and read its recorded fits back.

    Returns
    -------
    track : Track
        Frames without a recorded fit count as frames without a face;
        ``detections`` is -1 (the recording does not say).
    latency_ms : (K,) array
        Capture to fit publication of each recorded fit.
    wall : float
        Seconds the whole run took, start and stop of the services included.
    """
    from proto import Fit
    from services.stack.export import results_of
    from services.stack.recorder import load_messages

    rec = folder / f"{clip.video.parent.name}.rec"
    command = [sys.executable, "-m", "services", "run", "--video", str(clip.video),
               "--record", str(rec), "--pace", "fast", "--no-ar", "--no-smooth",
               "--model", str(model_path), "--algorithm", algorithm]
    env = os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO_ROOT)}
    t0 = time.perf_counter()
    done = subprocess.run(command, cwd=REPO_ROOT, env=env, capture_output=True, text=True,
                          timeout=600, check=False)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} exited {done.returncode}:\n{done.stderr[-2000:]}")
    messages = load_messages(rec)
    fits = [m for m in messages if isinstance(m, Fit)]
    latency = np.array([(f.header.publish_time_ns - f.header.capture_time_ns) / 1e6
                        for f in fits])
    by_frame = {r.frame_index: r for r in results_of(messages).results}
    frames = len(clip.truth.landmarks) if clip.truth is not None else max(by_frame, default=-1) + 1
    empty = np.zeros((0, 2))
    results = [by_frame.get(k) for k in range(frames)]
    track = Track(np.array([r is not None and r.success for r in results], bool),
                  np.array([r is not None and len(r.landmarks) > 0 for r in results], bool),
                  [empty if r is None else r.landmarks for r in results],
                  np.full(frames, np.nan), -1)
    return track, latency, wall


def agreement(library: Track, stack: Track) -> str:
    """On how many frames the stack and the library agree, and by how much their points differ."""
    same = int(np.sum(library.success == stack.success))
    both = [k for k in range(len(library.success))
            if library.found[k] and stack.found[k]
            and library.landmarks[k].shape == stack.landmarks[k].shape]
    gap = max((float(np.abs(library.landmarks[k] - stack.landmarks[k]).max()) for k in both),
              default=float("nan"))
    return (f"same good/failed verdict on {same} of {len(library.success)} frames; "
            f"largest landmark difference {gap:.4f} px over {len(both)} frames with a fit in both")


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = options.parser(__doc__, __name__, model=True)
    parser.add_argument("--algorithm", choices=list(ALGORITHMS), default=defaults.ALGORITHM,
                        help=f"fitting algorithm (default {defaults.ALGORITHM})")
    parser.add_argument("--split-model", action="store_true",
                        help="instead, the default model's recipe trained on the LFPW split's "
                             "training part only (trained once, cached)")
    parser.add_argument("--per-set", type=int, default=4, help="sequences per set")
    parser.add_argument("--frames", type=int, default=150, help="frames per sequence")
    parser.add_argument("--via-stack", type=int, nargs="?", const=2, default=0, metavar="N",
                        help="also run the first N generated videos through aamtrack run "
                             "(default N: 2)")
    parser.add_argument("--regenerate", action="store_true",
                        help="generate and write the sequences again")
    parser.add_argument("--nonrigid", type=int, default=2, metavar="N",
                        help="non-rigid sequences per set (default 2)")
    parser.add_argument("--schemes", nargs="+", default=list(SCHEMES), metavar="SCHEME",
                        help=f"schemes compared per part (default {' '.join(SCHEMES)})")
    parser.add_argument("--no-refit", action="store_true",
                        help="the library's tracker without refits from the mean face "
                             "(Refit NEVER)")
    parser.add_argument("--parts-only", action="store_true",
                        help="only the per-part comparison of the schemes")
    return options.parse(parser, argv)


def split_model_path() -> Path:
    """The default model's recipe trained on the training part of the LFPW split only.

    The default model learns from every LFPW photo, the held-out ones too; this one leaves
    them out, so that LFPW's sequences can be measured. Trained once (about a minute) and
    cached.
    """
    from aamcore.fitting.training import prepare
    from aamcore.model.cache import cache_key, cached_file
    from aamcore.model.training import train_aam

    config = prepare.AAM_CONFIG  # as default_model_path
    folder = resolve_dataset(defaults.MODEL_DATASET)
    images = defaults.MODEL_UPDATE_IMAGES
    key = cache_key(str(folder), config, {"select": "split train",
                                          "prepare": f"{prepare.RECIPE}, {images} images"})

    def build(path: Path) -> Path:
        data = load_annotated_folder(folder)
        train, _ = split(data.samples, set_name_of(folder))
        print(f"training the split model on {len(train)} images of {folder}, once", file=sys.stderr)
        aam = train_aam(train, data.scheme, config, source=f"{folder} [split train]")
        return prepare.train_fitting_model(aam, train, max_images=images).save(path)

    return cached_file(cache_dir() / f"{folder.name}-split-{key}.npz", build, FittingModel.load)


def load_model(args: argparse.Namespace) -> tuple[Path, FittingModel]:
    """The model of ``--model``, ``--split-model`` or the default model."""
    path = split_model_path() if args.split_model and args.model is None else (
        options.model_path(args))
    return path, FittingModel.load(path)


def library_runs(tracker: FaceTracker, clips: list[Clip], scheme: LandmarkScheme
                 ) -> tuple[dict[str, Track], dict[str, Score]]:
    """Track and score every clip through the library."""
    tracks, scores = {}, {}
    for clip in clips:
        frames, fps = read_clip(clip.video)
        tracks[clip.name] = track(tracker, frames, fps)
        scores[clip.name] = score(tracks[clip.name], clip.truth, scheme)
    return tracks, scores


def print_table(clips: list[Clip], scores: dict[str, Score]) -> Score:
    """The table of every clip, a summary per set, overall and over the non-rigid ones; the
    overall score of the rigid generated sequences (the targets')."""
    print(HEADER)
    groups: dict[str, list[Score]] = {}
    for clip in clips:
        groups.setdefault(clip.set_name, []).append(scores[clip.name])
    for set_name, group in groups.items():
        for clip in (c for c in clips if c.set_name == set_name):
            print(row(clip.name, scores[clip.name]))
        if set_name != "video":
            print(row(f"= {set_name} ({len(group)})", pooled(group)))
        print()
    generated = [s for name, group in groups.items()
                 if name != "video" and not name.endswith(NONRIGID) for s in group]
    overall = pooled(generated)
    print(row(f"= overall ({len(generated)})", overall))
    nonrigid = [s for name, group in groups.items() if name.endswith(NONRIGID) for s in group]
    if nonrigid:
        print(row(f"= overall{NONRIGID} ({len(nonrigid)})", pooled(nonrigid)))
    return overall


def via_stack(clips: list[Clip], tracks: dict[str, Track], model_path: Path, algorithm: str,
              scheme: LandmarkScheme) -> None:
    """Run clips through ``aamtrack run`` and compare with the library's runs."""
    print(f"\nThe same through the stack (aamtrack run --pace fast --no-ar --no-smooth, "
          f"--algorithm {algorithm}):")
    print(HEADER)
    with tempfile.TemporaryDirectory(prefix="bench-tracking-") as folder:
        for clip in clips:
            run, latency, wall = stack_track(clip, model_path, algorithm, Path(folder))
            print(row(f"stack {clip.name}", score(run, clip.truth, scheme)))
            print(f"  {agreement(tracks[clip.name], run)}")
            print(f"  fit latency (capture to fit) median {np.median(latency):.1f} ms, "
                  f"p95 {np.percentile(latency, 95):.1f} ms; run {wall:.1f} s with start and stop")


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    cv2.setNumThreads(1)
    start = time.perf_counter()
    with threadpool_limits(1):
        model_path, model = load_model(args)
        scheme = model.aam.scheme
        if scheme.n_points != 68:
            raise SystemExit(f"{model_path}: {scheme.name} points; the sequences have iBUG-68")
        tracker = FaceTracker(model=model, classifier=False,
                              landmark_smoothing=False, pose_smoothing=False,
                              algorithm=args.algorithm,
                              **({"refit": NEVER} if args.no_refit else {}))
        print(f"{tracker.fit.fitter.name} ({args.algorithm}), model {model_path.name} "
              f"({model.aam.summary.get('source', '?')}); OMP_NUM_THREADS="
              f"{os.environ.get('OMP_NUM_THREADS')}, one OpenCV thread")
        generated = generated_clips(model, args.per_set, args.frames, args.regenerate)
        nonrigid = nonrigid_clips(model, args.nonrigid, args.frames, args.regenerate)
        ok = True
        if not args.parts_only:
            clips = [Clip("video", "single_face.mp4",
                          data_root() / "videos" / "single_face.mp4", None), *generated,
                     *nonrigid]
            print()
            tracks, scores = library_runs(tracker, clips, scheme)
            overall = print_table(clips, scores)
            print()
            ok = verdicts(overall)
        compare_parts(tracker.fit.fitter, generated, nonrigid, args.schemes,
                      scheme)
        if args.via_stack and not args.parts_only:
            via_stack(generated[: args.via_stack], tracks, model_path, args.algorithm, scheme)
    print(f"\nbench time {time.perf_counter() - start:.0f} s")
    return 0 if ok else 1


def compare_parts(fitter: Fitter, rigid: list[Clip], nonrigid: list[Clip], names: list[str],
                  scheme: LandmarkScheme) -> None:
    """The per-part table of every scheme on the rigid and on the non-rigid sequences."""
    schemes = [parse_scheme(name) for name in names]
    for title, clips in (("rigid", rigid), ("non-rigid", nonrigid)):
        if not clips:
            continue
        print(f"\nPer part, {title} sequences ({len(clips)}, {sum(c.truth.frames for c in clips)}"
              " frames); good fits outside the occluder, and those with NME < 0.08; NME "
              "mean/p95 of the good fits outside the occluder; common: mean NME "
              "of the frames every scheme fits well; time of the tracker (or fitter) alone; "
              "refits: share of frames, kept: share of refits")
        print(PARTS_HEADER)
        pools = {s.name: Pool.empty() for s in schemes}
        for clip in clips:
            frames, _ = read_clip(clip.video)
            runs = {s.name: run_scheme(s, fitter, frames, clip.truth) for s in schemes}
            common = np.logical_and.reduce([r.ok for r in runs.values()]) & ~clip.truth.occluded
            for name, run in runs.items():
                pools[name].add(run, clip.truth, scheme)
                pools[name].add_common(run, clip.truth, scheme, common)
        for s in schemes:
            print(pool_row(s.name, pools[s.name]))

