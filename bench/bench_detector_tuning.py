"""Tune the Haar detector on the training split of LFPW, HELEN and AFW.

Run: ``AAMTRACK_DATA=... OMP_NUM_THREADS=1 python -m bench detector-tuning``

For every cascade, scale factor, least face size and longest side searched
(``max_side``: images downscaled to it first, as
:class:`~aamcore.detection.haar.HaarFaceDetector` does; ``-`` for full size),
each image is scanned once with ``minNeighbors=0`` (OpenCV then returns the raw
windows) and timed on one thread. The detections for ``minNeighbors = k`` are
the raw windows grouped by ``cv2.groupRectangles(raw, k, 0.2)`` at the scale
searched, exactly what ``detectMultiScale`` does itself, then mapped back. A
face counts as found when a detection matches it
(:func:`aamcore.detection.boxes.match_detection`).

Prints, on the training split, the detection rate per set, the rate of the
largest box being the face, the extra boxes per image and the median scan time
per image (at most 512 px) and per 640x360 frame of ``videos/single_face.mp4``;
then the chosen setting and the current default on the held-out split. Raw
windows are cached under ``cache_dir()/research``.
"""

from __future__ import annotations

import json
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2
import numpy as np

from aamcore import defaults
from aamcore.config import cache_dir, data_root, resolve_dataset
from aamcore.detection.boxes import match_detection
from aamcore.detection.haar import cascade_path
from aamcore.io import load_annotated_folder
from aamcore.io.splits import SPLIT_SETS, is_held_out
from aamcore.io.video import video_frames
from bench import options

SCANS = [
    ("haarcascade_frontalface_alt2.xml", 1.2, 60, 320),  # the project's setting before
    ("haarcascade_frontalface_alt2.xml", 1.2, 60, 0),
    ("haarcascade_frontalface_alt2.xml", 1.1, 60, 0),  # the research's choice (min_nb 2)
    ("haarcascade_frontalface_alt2.xml", 1.1, 60, 320),
    ("haarcascade_frontalface_alt2.xml", 1.1, 40, 320),
    ("haarcascade_frontalface_alt2.xml", 1.05, 60, 320),
]
NEIGHBOURS = (2, 3)


def scan_key(cascade: str, factor: float, min_size: int, max_side: int) -> str:
    name = cascade.removeprefix("haarcascade_").removesuffix(".xml")
    return f"{name}-{factor}-{min_size}-{max_side or '-'}"


def shrink(grey: np.ndarray, min_size: int, max_side: int) -> tuple[np.ndarray, float, int]:
    """The image as the detector searches it, the factor back to the image and the least size."""
    if not max_side or max(grey.shape) <= max_side:
        return grey, 1.0, min_size
    f = max_side / max(grey.shape)
    size = (max(1, round(grey.shape[1] * f)), max(1, round(grey.shape[0] * f)))
    return cv2.resize(grey, size, interpolation=cv2.INTER_AREA), f, max(1, round(min_size * f))


def scan(setting: tuple, faces: list, frames: list) -> dict:
    """Raw windows of every face image (in image pixels) and the median times of one setting."""
    cascade, factor, min_size, max_side = setting
    classifier = cv2.CascadeClassifier(str(cascade_path(cascade)))
    boxes, seconds = {}, []
    for _, name, sample, _ in faces:
        grey = cv2.cvtColor(sample.load_image(), cv2.COLOR_BGR2GRAY)
        t0 = time.perf_counter()
        small, f, least = shrink(grey, min_size, max_side)
        raw = classifier.detectMultiScale(small, factor, 0, minSize=(least, least))
        seconds.append(time.perf_counter() - t0)
        boxes[name] = {"raw": np.asarray(raw).reshape(-1, 4).tolist(), "factor": f}
    frame_seconds = []
    for grey in frames:
        t0 = time.perf_counter()
        small, f, least = shrink(grey, min_size, max_side)
        classifier.detectMultiScale(small, factor, 3, minSize=(least, least))
        frame_seconds.append(time.perf_counter() - t0)
    return {"boxes": boxes, "ms_image": 1000 * float(np.median(seconds)),
            "ms_frame": 1000 * float(np.median(frame_seconds))}


def rates(entry: dict, faces: list, k: int, held: bool) -> list[float]:
    """Detection rate per set and in all, the rate of the largest box being the face and the
    mean number of boxes that are not the face."""
    out, total, largest, extra = [], [], [], []
    for set_name in SPLIT_SETS:
        hits = []
        for s_name, name, sample, h in faces:
            if s_name != set_name or h != held:
                continue
            raw, f = entry["boxes"][name]["raw"], entry["boxes"][name]["factor"]
            found, _ = cv2.groupRectangles(raw, k, 0.2) if raw else ((), None)
            found = np.asarray(found, dtype=np.float64).reshape(-1, 4) / f
            m = match_detection(found, sample.points)
            hits.append(m is not None)
            order = np.argsort(-(found[:, 2] * found[:, 3]), kind="stable")
            largest.append(m is not None and order[0] == m)
            extra.append(len(found) - (m is not None))
        out.append(float(np.mean(hits)))
        total += hits
    return out + [float(np.mean(total)), float(np.mean(largest)), float(np.mean(extra))]


def main(argv: list[str] | None = None) -> None:
    parser = options.parser(__doc__, __name__)
    parser.add_argument("--choose", default="frontalface_alt2-1.1-60-320:2",
                        help="KEY:MIN_NEIGHBORS reported on the held-out split")
    args = options.parse(parser, argv)
    cv2.setNumThreads(1)
    path = cache_dir() / "research" / "haar_raw_port.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    cache = json.loads(path.read_text()) if path.exists() else {}
    faces = []
    for set_name in SPLIT_SETS:
        for s in load_annotated_folder(resolve_dataset(set_name)).samples:
            held = is_held_out(s.image_path.stem, set_name)
            faces.append((set_name, f"{set_name}/{s.image_path.stem}", s, held))
    frames = [cv2.cvtColor(f, cv2.COLOR_BGR2GRAY)
              for f in video_frames(data_root() / "videos" / "single_face.mp4")][::6]
    for setting in SCANS:
        key = scan_key(*setting)
        if key not in cache:
            cache[key] = scan(setting, faces, frames)
            path.write_text(json.dumps(cache))
            print(f"scanned {key}", flush=True)
    header = f"{'setting':<36}{'min_nb':>7}" + "".join(f"{s:>8}" for s in SPLIT_SETS)
    print(f"\ntraining split ({sum(not f[3] for f in faces)} faces): detection rate; "
          "median ms per image (<= 512 px) / per 640x360 frame, one thread")
    print(header + f"{'all':>8}{'largest':>8}{'extra':>7}{'ms img':>8}{'ms vid':>8}")
    for setting in SCANS:
        key = scan_key(*setting)
        for k in NEIGHBOURS:
            r = rates(cache[key], faces, k, held=False)
            print(f"{key:<36}{k:>7}" + "".join(f"{v:>8.1%}" for v in r[:-1])
                  + f"{r[-1]:>7.3f}{cache[key]['ms_image']:>8.1f}{cache[key]['ms_frame']:>8.1f}")
    key, k = args.choose.rsplit(":", 1)
    d = defaults.DETECTOR
    current = scan_key("haarcascade_frontalface_alt2.xml", d["scale_factor"], d["min_size"][0],
                       d["max_side"] or 0)
    print(f"\nheld-out split ({sum(f[3] for f in faces)} faces), {key} min_neighbors {k} "
          f"and the default of aamcore.defaults.DETECTOR ({current}, {d['min_neighbors']}):")
    print(header + f"{'all':>8}{'largest':>8}{'extra':>7}")
    for name, kk in ((scan_key(*SCANS[0]), 3), (key, int(k)), (current, d["min_neighbors"])):
        if name in cache:
            r = rates(cache[name], faces, kk, held=True)
            print(f"{name:<36}{kk:>7}" + "".join(f"{v:>8.1%}" for v in r[:-1])
                  + f"{r[-1]:>7.3f}")

