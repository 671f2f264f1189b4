"""Fitting speed on one core: tracking from the previous frame and starting from a Haar box.

Run: ``python -m bench fit-speed [--model FILE] [--letterbox]``

Uses the stack's default model (trained on the training splits of LFPW, HELEN
and AFW, cached on first use) or ``--model``, on the frames of
``videos/single_face.mp4`` (640x360; ``--letterbox`` puts them on a 640x480
canvas as before), every method through the
:class:`~aamcore.fitting.fitter.Fitter` with its default failure test.
Tracking fits each frame from the previous frame's fit; the Haar start fits
each frame from its detection (detection timed apart). Targets: the default
method tracks >= 1000 fits/s, fits from a Haar box >= 50 fits/s;
supervised-descent tracks >= 300 fits/s.

The AAM's appearance of every good fit: the default method's tracking of the
video timed as the landmarks only (``--no-appearance``), with the appearance
(``c`` and the texture residual: one CPU warp and the projection), with the
occlusion flags too (the default), and with three fixed-Jacobian refinement
iterations, each over the whole video in turn, three times; the median of the
per-frame differences is what each adds. Target: the appearance and flags add
<= 0.5 ms.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2
import numpy as np
from threadpoolctl import threadpool_limits

from aamcore import defaults
from aamcore.config import data_root
from aamcore.detection.haar import HaarFaceDetector
from aamcore.fitting.algorithm import ALGORITHMS
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.io.video import video_frames
from bench import options
from bench.targets import Target

TRACK = Target("default method tracking, fits/s on one core", ">=", 1000.0, "fits/s")
BOX = Target("default method from a Haar box, fits/s on one core", ">=", 50.0, "fits/s")
APPEARANCE = Target("the AAM's appearance and occlusion flags, added per tracked frame", "<=",
                    0.5, "ms")
VS_DLIB = Target("tracking with appearance and flags against dlib's rate, same run", ">=", 2.2,
                 "x")
SDM_TRACK = Target("supervised-descent (the AAM methods' best) tracking, fits/s", ">=", 300.0,
                   "fits/s")
TARGETS = (TRACK, BOX, APPEARANCE, VS_DLIB, SDM_TRACK)


def letterbox(frame: np.ndarray, size: tuple[int, int] = (640, 480)) -> np.ndarray:
    """``frame`` scaled to fit ``size`` (width, height), centred on black."""
    canvas = np.zeros((size[1], size[0], 3), np.uint8)
    h, w = frame.shape[:2]
    scale = min(size[0] / w, size[1] / h)
    frame = cv2.resize(frame, (int(w * scale), int(h * scale)))
    y, x = (size[1] - frame.shape[0]) // 2, (size[0] - frame.shape[1]) // 2
    canvas[y : y + frame.shape[0], x : x + frame.shape[1]] = frame
    return canvas


def rate(seconds: list[float]) -> tuple[float, float]:
    """Fits per second (from the median) and the median in ms."""
    median = float(np.median(seconds))
    return 1.0 / median, 1000 * median


VARIANTS = {
    "landmarks only (--no-appearance)": {"appearance": False},
    "+ appearance c, texture residual": {"occlusion": False},
    "+ occlusion flags (the default)": {},
    "+ 3 fixed-Jacobian iterations (--refine 3)": {"refine": 3},
}
"""The default method's configurations timed against each other."""


def appearance_cost(model: FittingModel, frames: list[np.ndarray], boxes: list) -> float:
    """Print what each of :data:`VARIANTS` adds to tracking a frame; the default's addition
    over the landmarks alone (median ms of the per-frame differences).

    Each variant tracks the whole video in a block (its matrices stay in the cache, as in
    the fitter's process), the blocks in turn, three times over; frame ``k`` of one
    variant is paired with frame ``k`` of the landmarks' block of the same pass.
    """
    fitters = {name: Fitter(model, **kw) for name, kw in VARIANTS.items()
               if "refine" not in kw or model.updates}
    times: dict[str, list[float]] = {name: [] for name in fitters}
    with threadpool_limits(1):
        for _ in range(3):
            for name, fitter in fitters.items():
                previous = None
                for frame, box in zip(frames, boxes, strict=True):
                    if box is None:
                        continue
                    if previous is None:
                        previous = fitter.fit_box(frame, box)
                        continue
                    t0 = time.perf_counter()
                    previous = fitter.track(frame, previous)
                    times[name].append(time.perf_counter() - t0)
    base = np.array(times["landmarks only (--no-appearance)"])
    print(f"\n{'default method, tracking':<44}{'ms':>8}{'added ms':>10}")
    added = {}
    for name, values in times.items():
        n = min(len(values), len(base))
        added[name] = float(np.median(1000 * (np.array(values[:n]) - base[:n])))
        print(f"{name:<44}{1000 * np.median(values):>8.3f}{added[name]:>10.3f}")
    return added["+ occlusion flags (the default)"]


def part_split(model: FittingModel, frames: list[np.ndarray], box: np.ndarray) -> None:
    """Print where the default method's tracked frame goes, part by part (median ms of each
    part timed alone at the tracked landmarks, the parts in turn on each frame of the video,
    five times; the fitter's own work is the whole less the parts)."""
    fitter = Fitter(model)
    lb, sampler = fitter.algorithm, fitter.sampler
    fits, previous = [], fitter.fit_box(frames[0], box)
    for frame in frames[1:]:
        fits.append((frame, previous))
        previous = fitter.track(frame, previous)
    regions = [lb.region(f, p.points) for f, p in fits]
    starts = [lb.placed_mean(p.points) - r.origin for (_, p), r in zip(fits, regions, strict=True)]
    restarted = [lb.project(lb._stages(r, s, lb._restart, [])) for r, s in
                 zip(regions, starts, strict=True)]
    pairs = [np.stack([p.points - r.origin, s]) for (_, p), r, s in
             zip(fits, regions, restarted, strict=True)]
    ends = [lb._paired_stages(r, b, []) for r, b in zip(regions, pairs, strict=True)]
    tracked = [fitter.track(f, p).points for f, p in fits]
    greys = [(r.pixels.reshape(-1, r.width), t - r.origin) for r, t in
             zip(regions, tracked, strict=True)]
    found = [sampler._sample(*g) for g in greys]
    features = [sampler._features(*x) for x in found]
    outside = np.zeros(model.aam.scheme.n_points, bool)
    parts: dict[str, Callable[[int], object]] = {
        "Fitter.track, the default (all)": lambda k: fitter.track(*fits[k]),
        "grey region of the face (cvtColor)": lambda k: lb.region(fits[k][0], fits[k][1].points),
        "restart stages (3) + projection": lambda k: lb.project(lb._stages(
            regions[k], starts[k], lb._restart, [])),
        "fern stages (3, both fits at once)": lambda k: lb._paired_stages(regions[k], pairs[k],
                                                                          []),
        "projections + quality score": lambda k: lb._score(regions[k], 0.5 * (
            lb.project(ends[k][0]) + lb.project(ends[k][1]))),
        "appearance: warp, c, residual (one pass)": lambda k: sampler._sample(*greys[k]),
        "  of it, the box warp (remap)": lambda k: sampler.box.sample(*greys[k]),
        "occlusion: features (Sobel, discs)": lambda k: sampler._features(*found[k]),
        "occlusion: two networks": lambda k: fitter.sampler.occlusion(features[k], outside),
    }
    if fitter.sampler.occlusion is None:
        parts = {k: v for k, v in parts.items() if not k.startswith("occlusion")}
    times: dict[str, list[float]] = {name: [] for name in parts}
    with threadpool_limits(1):  # the parts in turn on each frame: each sees the same load
        for _ in range(5):
            for k in range(len(fits)):
                for name, part in parts.items():
                    t0 = time.perf_counter()
                    part(k)
                    times[name].append(time.perf_counter() - t0)
    medians = {name: 1000 * float(np.median(v)) for name, v in times.items()}
    whole = medians.pop("Fitter.track, the default (all)")
    print(f"\n{'where a tracked frame goes (default method)':<44}{'ms':>8}{'share':>8}")
    for name, ms in medians.items():
        print(f"{name:<44}{ms:>8.3f}{ms / whole:>8.1%}")
    rest = whole - sum(ms for n, ms in medians.items() if not n.startswith("  "))
    print(f"{'the fitter and the glue (the rest)':<44}{rest:>8.3f}{rest / whole:>8.1%}")
    print(f"{'all':<44}{whole:>8.3f}")


DLIB_PREDICTOR = Path(os.environ.get(
    "DLIB_PREDICTOR", Path.home() / ".cache/aamtrack/dlib/shape_predictor_68_face_landmarks.dat"))
"""dlib's 68-point model (``bench_vs_dlib.py`` finds it the same way)."""


def versus_dlib(model: FittingModel, frames: list[np.ndarray], box: np.ndarray,
                passes: int = 10) -> float | None:
    """The default method's tracking (appearance and flags) against dlib's predictor in the
    same run, each from its own previous landmarks (dlib on the grey frame, converted outside
    its timing, from its previous landmarks' box); the median over ``passes`` pairs of the
    ratio of the two passes' median times (None without dlib or its model).

    Each pass tracks the whole video, ours then dlib's, so that each keeps its tables in the
    cache as its own process would; the pass pairs show how far the machine's speed moves
    both. A third figure tracks frame by frame in turns: each evicts the other's tables
    (dlib's forest is 99 MB), the cost of sharing a core and its cache.
    """
    try:
        import dlib
    except ImportError:
        print("\ndlib is not installed: no comparison (pip install dlib-bin)")
        return None
    if not DLIB_PREDICTOR.exists():
        print(f"\nno dlib model at {DLIB_PREDICTOR} (set DLIB_PREDICTOR): no comparison")
        return None
    predictor = dlib.shape_predictor(str(DLIB_PREDICTOR))
    greys = [cv2.cvtColor(f, cv2.COLOR_BGR2GRAY) for f in frames]
    fitter = Fitter(model)

    def dlib_step(grey: np.ndarray, previous: np.ndarray) -> np.ndarray:
        (x0, y0), (x1, y1) = previous.min(axis=0), previous.max(axis=0)
        rect = dlib.rectangle(int(x0), int(y0), int(x1), int(y1))
        shape = predictor(grey, rect)
        return np.array([(p.x, p.y) for p in shape.parts()], np.float64)

    def timed(step: Callable, image: np.ndarray, start: object) -> tuple[object, float]:
        t0 = time.perf_counter()
        return step(image, start), time.perf_counter() - t0

    ours, theirs, mixed = [], [], ([], [])
    with threadpool_limits(1):
        for _ in range(passes):
            previous = fitter.fit_box(frames[0], box)
            times = []
            for frame in frames[1:]:
                previous, seconds = timed(fitter.track, frame, previous)
                times.append(seconds)
            ours.append(np.median(times))
            points, times = previous.points, []
            for grey in greys[1:]:
                points, seconds = timed(dlib_step, grey, points)
                times.append(seconds)
            theirs.append(np.median(times))
        previous = fitter.fit_box(frames[0], box)
        points = previous.points
        for frame, grey in zip(frames[1:], greys[1:], strict=True):
            previous, seconds = timed(fitter.track, frame, previous)
            mixed[0].append(seconds)
            points, seconds = timed(dlib_step, grey, points)
            mixed[1].append(seconds)
    mine, dlibs = 1000 * np.array(ours), 1000 * np.array(theirs)
    ratios = dlibs / mine
    print(f"\nthe same run, {passes} pass pairs in turns (median ms of each pass, min-max):"
          f"\n  Fitter.track (appearance and flags) {np.median(mine):.3f} "
          f"({mine.min():.3f}-{mine.max():.3f}), dlib {np.median(dlibs):.3f} "
          f"({dlibs.min():.3f}-{dlibs.max():.3f}); dlib / ours per pair {np.median(ratios):.2f}"
          f" ({ratios.min():.2f}-{ratios.max():.2f})")
    a, b = (1000 * float(np.median(m)) for m in mixed)
    print(f"  frame by frame in turns (each evicts the other's tables): ours {a:.3f}, "
          f"dlib {b:.3f}, {b / a:.2f}x")
    return float(np.median(ratios))


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__, model=True)
    parser.add_argument("--letterbox", action="store_true", help="frames on a 640x480 canvas")
    parser.add_argument("--methods", nargs="+", default=list(ALGORITHMS),
                        help="the methods of the first table (default: all)")
    args = options.parse(parser, argv)
    cv2.setNumThreads(1)
    frames = video_frames(data_root() / "videos" / "single_face.mp4")
    if args.letterbox:
        frames = [letterbox(f) for f in frames]
    model = FittingModel.load(options.model_path(args))
    aam = model.aam
    detector = HaarFaceDetector()
    det_times, boxes = [], []
    for frame in frames:
        t0 = time.perf_counter()
        found = detector.detect(frame)
        det_times.append(time.perf_counter() - t0)
        boxes.append(found[0] if len(found) else None)
    print(f"{len(frames)} frames {frames[0].shape[1]}x{frames[0].shape[0]}, model AAM "
          f"{aam.frame.n_pixels} px "
          f"{'grey' if aam.channels == 1 else 'colour'}, one core")
    print(f"Haar detection: {1000 * np.median(det_times):.1f} ms median "
          f"({sum(b is not None for b in boxes)} of {len(frames)} frames with a face)\n")
    print(f"{'algorithm':<44}{'track fits/s':>13}{'ms':>7}{'box fits/s':>11}{'ms':>7}"
          f"{'iters':>6}")
    results = {}
    with threadpool_limits(1):
        for name in args.methods:
            fitter = Fitter(model, name)
            box_times, track_times, iterations = [], [], []
            previous = None
            for frame, box in zip(frames, boxes, strict=True):
                if box is None:
                    continue
                t0 = time.perf_counter()
                fit = fitter.fit_box(frame, box)
                box_times.append(time.perf_counter() - t0)
                if previous is not None:
                    t0 = time.perf_counter()
                    fit = fitter.track(frame, previous)
                    track_times.append(time.perf_counter() - t0)
                iterations.append(getattr(fit, "iterations", len(fit.seconds)))
                previous = fit
            track, track_ms = rate(track_times)
            box_rate, box_ms = rate(box_times)
            results[name] = (track, box_rate)
            print(f"{fitter.name:<44}{track:>13.0f}{track_ms:>7.2f}{box_rate:>11.0f}{box_ms:>7.2f}"
                  f"{np.mean(iterations):>6.1f}")
    added = appearance_cost(model, frames, boxes)
    first = next(b for b in boxes if b is not None)
    start = next(k for k, b in enumerate(boxes) if b is not None)
    part_split(model, frames[start:], first)
    ratio = versus_dlib(model, frames[start:], first)
    track, box_rate = results[defaults.ALGORITHM]
    ok = TRACK.check(track, defaults.ALGORITHM) & BOX.check(box_rate, defaults.ALGORITHM)
    ok &= APPEARANCE.check(added, "median")
    if ratio is not None:
        ok &= VS_DLIB.check(ratio)
    if "supervised-descent" in results:
        ok &= SDM_TRACK.check(results["supervised-descent"][0])
    return 0 if ok else 1

