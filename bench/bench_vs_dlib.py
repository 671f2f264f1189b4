"""The default method against dlib's 68-point shape predictor, in one process.

Run: ``PYTHONPATH=. OMP_NUM_THREADS=1 python -m bench vs-dlib [--model FILE]``

- Stills: every held-out face of LFPW, HELEN and AFW (the project's split),
  both systems started from the same Haar box (the default detector,
  :data:`aamcore.defaults.DETECTOR`; the landmark box where Haar misses,
  counted), the box mapped into each system's own convention by a mapping
  learned on the training split: ours by the model's box-to-shape mapping
  (:meth:`Fitter.fit_box`), dlib's by a box-relative mapping from the Haar box
  (or the landmark box) to the box dlib's own HOG face detector gives on the
  training images. NME mean, median, failures (> 0.08, > 0.10) and time per
  fit, and their ratios to dlib; then per part of the face (jaw, mouth, brows, nose,
  eyes) both systems' mean NME and their ratio.
- Video: ``videos/single_face.mp4`` (640x360, 72 frames), both started on frame
  0 from the same Haar box, then each tracks from its own previous landmarks
  (dlib: its predictor on the mapped box of its previous landmarks) for
  ``--passes`` passes, one thread; time per tracked frame of ours through the
  :class:`~aamcore.fitting.fitter.Fitter` (what the tracker calls: image check,
  the fern stages, the quality test) and of the bare method, as rates and
  ratios to dlib's in the same run.

dlib gets the grey image, converted outside its timing; ours converts the face
region of the BGR frame inside its timing.

Caveat: dlib's model was trained on the 300-W training sets, which include these
LFPW, HELEN and AFW images, held-out split or not: its numbers here are on faces
it was trained on.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2
import dlib
import numpy as np
from threadpoolctl import threadpool_limits

from aamcore.config import cache_dir, data_root, resolve_dataset
from aamcore.detection.boxes import landmark_box, match_detection
from aamcore.detection.haar import HaarFaceDetector
from aamcore.evaluation.fits import haar_box
from aamcore.evaluation.metrics import nme, part_nmes
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.io import load_annotated_folder
from aamcore.io.landmarks import IBUG68
from aamcore.io.splits import SPLIT_SETS, split
from aamcore.io.video import video_frames
from bench import options

PREDICTOR = Path(os.environ.get(
    "DLIB_PREDICTOR", Path.home() / ".cache/aamtrack/dlib/shape_predictor_68_face_landmarks.dat"))


def faces_of(set_name: str) -> tuple[list, list]:
    """The training and held-out faces of one set."""
    return split(load_annotated_folder(resolve_dataset(set_name)).samples, set_name)


def dlib_training_boxes(train: list) -> dict[str, list[float]]:
    """dlib's HOG detector box matched to each training face ``set/stem`` (cached)."""
    path = cache_dir() / "research" / "dlib_train_boxes.json"
    if path.exists():
        return json.loads(path.read_text())
    detector = dlib.get_frontal_face_detector()
    out = {}
    for name, sample in train:
        grey = cv2.cvtColor(sample.load_image(), cv2.COLOR_BGR2GRAY)
        rects = detector(grey, 0)
        boxes = np.array([[r.left(), r.top(), r.width(), r.height()] for r in rects], float)
        k = match_detection(boxes.reshape(-1, 4), sample.points)
        if k is not None:
            out[name] = boxes[k].tolist()
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(out))
    return out


class DlibBoxMapping:
    """Box-relative map from a source box to dlib's box: centre shift and size, per unit width."""

    def __init__(self, sources: np.ndarray, targets: np.ndarray) -> None:
        w = sources[:, 2]
        centre_s = sources[:, :2] + sources[:, 2:] / 2
        centre_t = targets[:, :2] + targets[:, 2:] / 2
        self.shift = np.mean((centre_t - centre_s) / w[:, None], axis=0)
        self.size = float(np.mean(targets[:, 2] / w))

    def rect(self, box: np.ndarray) -> dlib.rectangle:
        x, y, w, h = box
        cx, cy = x + w / 2 + self.shift[0] * w, y + h / 2 + self.shift[1] * w
        half = self.size * w / 2
        return dlib.rectangle(int(round(cx - half)), int(round(cy - half)),
                              int(round(cx + half)), int(round(cy + half)))


def dlib_mappings(train: list, detector: HaarFaceDetector) -> tuple[DlibBoxMapping, ...]:
    """dlib's box from our Haar box and from the landmark box, learned on training faces."""
    boxes = dlib_training_boxes(train)
    haar, theirs, marks = [], [], []
    for name, sample in train:
        if name not in boxes:
            continue
        marks.append((landmark_box(sample.points), boxes[name]))
        found = haar_box(detector, sample.load_image(), sample.points)
        if found is not None:
            haar.append(found)
            theirs.append(boxes[name])
    from_haar = DlibBoxMapping(np.array(haar), np.array(theirs))
    from_marks = DlibBoxMapping(np.array([m for m, _ in marks]), np.array([d for _, d in marks]))
    print(f"dlib box mappings from {len(marks)} training faces dlib's detector found (of "
          f"{len(train)}), {len(haar)} also by Haar: from Haar shift "
          f"{np.round(from_haar.shift, 3).tolist()} size {from_haar.size:.3f}")
    return from_haar, from_marks


def points_of(shape: dlib.full_object_detection) -> np.ndarray:
    return np.array([[p.x, p.y] for p in shape.parts()], dtype=np.float64)


def stats(errors: list[float]) -> dict[str, float]:
    e = np.asarray(errors)
    return {"mean": float(e.mean()), "median": float(np.median(e)),
            "f08": float(np.mean(e > 0.08)), "f10": float(np.mean(e > 0.10))}


def still(fitter, predictor, maps, detector, sample
          ) -> tuple[float, float, float, float, bool, dict[str, float], dict[str, float]]:
    """Both systems on one face from the same box: NMEs and seconds, whether Haar missed,
    and each system's NME per part of the face (``jaw``, ``mouth``, ...)."""
    image = sample.load_image()
    grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    box = haar_box(detector, image, sample.points)
    source = "detector" if box is not None else "landmarks"
    start = box if box is not None else landmark_box(sample.points)
    rect = maps[0 if box is not None else 1].rect(start)
    t0 = time.perf_counter()
    fit = fitter.fit_box(image, start, source)
    t1 = time.perf_counter()
    shape = predictor(grey, rect)
    t2 = time.perf_counter()
    theirs = points_of(shape)
    return (nme(fit.points, sample.points, IBUG68), nme(theirs, sample.points, IBUG68),
            t1 - t0, t2 - t1, box is None, part_nmes(fit.points, sample.points, IBUG68),
            part_nmes(theirs, sample.points, IBUG68))


PARTS = ("jaw", "mouth", "brows", "nose", "eyes")
"""The parts of the face whose NME the stills table gives apart."""


def part_cell(rows: list, part: str) -> str:
    """Ours and dlib's mean NME of one part over ``rows`` of :func:`still`, and the ratio."""
    ours, theirs = (float(np.mean([r[k][part] for r in rows])) for k in (5, 6))
    return f"{ours:>9.4f} /{theirs:.4f} {ours / theirs:>5.2f}x"


def stills(fitter, predictor, maps, detector, test: dict) -> None:
    """The held-out table."""
    print(f"\n{'set':<7}{'n':>5}{'miss':>5} | {'ours: mean':>11}{'median':>8}{'>0.08':>7}"
          f"{'>0.10':>7}{'ms':>7} | {'dlib: mean':>11}{'median':>8}{'>0.08':>7}{'>0.10':>7}"
          f"{'ms':>7} | {'NME ratio':>9}{'median r':>9}{'time ratio':>11}")
    every = ([], [])
    parts = {}
    for set_name, samples in test.items():
        rows = [still(fitter, predictor, maps, detector, s) for s in samples]
        parts[set_name] = rows
        ours, theirs = [r[0] for r in rows], [r[1] for r in rows]
        a, b = stats(ours), stats(theirs)
        every[0].extend(ours)
        every[1].extend(theirs)
        t_ours, t_dlib = np.median([r[2] for r in rows]), np.median([r[3] for r in rows])
        print(f"{set_name:<7}{len(rows):>5}{sum(r[4] for r in rows):>5} | {a['mean']:>11.4f}"
              f"{a['median']:>8.4f}{a['f08']:>7.1%}{a['f10']:>7.1%}{1000 * t_ours:>7.2f} | "
              f"{b['mean']:>11.4f}{b['median']:>8.4f}{b['f08']:>7.1%}{b['f10']:>7.1%}"
              f"{1000 * t_dlib:>7.2f} | {a['mean'] / b['mean']:>9.3f}"
              f"{a['median'] / b['median']:>9.3f}{t_ours / t_dlib:>11.2f}", flush=True)
    print(f"\nper part, mean NME (ours / dlib, ratio): {'':<2}"
          + "".join(f"{p:>24}" for p in PARTS))
    for set_name, rows in parts.items():
        print(f"{set_name:<38}" + "".join(part_cell(rows, p) for p in PARTS))
    print(f"{'all':<38}" + "".join(part_cell([r for rows in parts.values() for r in rows], p)
                                   for p in PARTS))
    a, b = stats(every[0]), stats(every[1])
    print(f"\n{'all':<7}{len(every[0]):>5}{'':>5} | {a['mean']:>11.4f}{a['median']:>8.4f}"
          f"{a['f08']:>7.1%}{a['f10']:>7.1%}{'':>7} | {b['mean']:>11.4f}{b['median']:>8.4f}"
          f"{b['f08']:>7.1%}{b['f10']:>7.1%}{'':>7} | {a['mean'] / b['mean']:>9.3f}"
          f"{a['median'] / b['median']:>9.3f}")


def _timed(step, state, frames: list) -> tuple[list[float], list]:
    """Run ``state = step(frame, state)`` over ``frames``: seconds per frame and the states."""
    seconds, states = [], []
    for frame in frames:
        t0 = time.perf_counter()
        state = step(frame, state)
        seconds.append(time.perf_counter() - t0)
        states.append(state)
    return seconds, states


def video(fitter: Fitter, predictor, maps, passes: int) -> float:
    """Track the video with both; print the rates and return ours (Fitter) / dlib.

    Each tracker runs over the frames in a loop of its own (so that each reads
    frames not in the cache, as a live tracker does), in turns within a pass.
    """
    frames = video_frames(data_root() / "videos" / "single_face.mp4")
    greys = [cv2.cvtColor(f, cv2.COLOR_BGR2GRAY) for f in frames]
    box = HaarFaceDetector().detect(frames[0])[0]
    method = fitter.algorithm
    first = fitter.fit_box(frames[0], box)
    theirs0 = points_of(predictor(greys[0], maps[0].rect(box)))
    runs = {
        "fitter": (lambda f, prev: fitter.track(f, prev), first, frames),
        "bare": (lambda f, prev: method.track_points(f, prev.points), first, frames),
        "dlib": (lambda g, prev: points_of(predictor(g, maps[1].rect(landmark_box(prev)))),
                 theirs0, greys),
    }
    times: dict[str, list[float]] = {k: [] for k in runs}
    states: dict[str, list] = {}
    for k in range(passes):
        order = list(runs)[k % 3:] + list(runs)[: k % 3]
        for name in order:
            step, start, inputs = runs[name]
            seconds, states[name] = _timed(step, start, inputs[1:])
            times[name] += seconds
    failed = sum(r.failed for r in states["fitter"])
    gaps = [np.linalg.norm(a.points - b, axis=1).mean() / IBUG68.inter_ocular(b)
            for a, b in zip(states["fitter"], states["dlib"], strict=True)]
    mf, mb, md = (float(np.median(times[k])) for k in ("fitter", "bare", "dlib"))
    print(f"\nsingle_face.mp4 {frames[0].shape[1]}x{frames[0].shape[0]}, {len(frames) - 1} "
          f"tracked frames x {passes} passes, one thread:")
    print(f"  ours (Fitter.track): {1000 * mf:.3f} ms per tracked frame ({1 / mf:.0f} fits/s), "
          f"quality test failed {failed} of {len(frames) - 1} (last pass)")
    print(f"  ours (bare method):  {1000 * mb:.3f} ms ({1 / mb:.0f} fits/s)")
    print(f"  dlib:                {1000 * md:.3f} ms ({1 / md:.0f} fits/s)")
    print(f"  RATIO ours/dlib rate: {md / mf:.2f}x through the Fitter, {md / mb:.2f}x bare; "
          f"mean distance between the two trackers' landmarks {np.mean(gaps):.4f} of the "
          "eye-corner distance")
    return float(md / mf)


def main(argv: list[str] | None = None) -> None:
    parser = options.parser(__doc__, __name__, model=True)
    parser.add_argument("--passes", type=int, default=5)
    parser.add_argument("--video-only", action="store_true", help="skip the stills")
    parser.add_argument("--repeats", type=int, default=1, help="video runs (the machine is noisy)")
    args = options.parse(parser, argv)
    cv2.setNumThreads(1)
    model = FittingModel.load(options.model_path(args))
    fitter = Fitter(model, "local-binary")
    predictor = dlib.shape_predictor(str(PREDICTOR))
    detector = HaarFaceDetector()
    train, test = [], {}
    for set_name in SPLIT_SETS:
        tr, te = faces_of(set_name)
        train += [(f"{set_name}/{s.image_path.stem}", s) for s in tr]
        test[set_name] = te
    maps = dlib_mappings(train, detector)
    print("NOTE: dlib's model was trained on 300-W, which includes these images.")
    with threadpool_limits(1):
        if not args.video_only:
            stills(fitter, predictor, maps, detector, test)
        ratios = [video(fitter, predictor, maps, args.passes) for _ in range(args.repeats)]
    print(f"\nvideo rate ratios ours (Fitter) / dlib over {args.repeats} run(s): "
          f"{', '.join(f'{r:.2f}' for r in ratios)}; median {np.median(ratios):.2f}x")

