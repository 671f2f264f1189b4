"""Bench: what a new user meets first, as whole processes: help at once, an annotated video at
least as fast as the video plays.

Run: ``python -m bench first-minutes [--runs 9] [--video FILE]``

1. **Help**: ``aamtrack --help``, ``aamtrack run --help`` and ``aamtrack track --help``, each
   the whole process, ``--runs`` times in turn: median and range of the wall time.
2. **Annotated video**: ``aamtrack track VIDEO --csv`` with and without ``--annotate OUT.mp4``,
   in turn (default model and its classifier, trained first if need be): the tracking loop's
   frames per second as the command reports it (after the models are loaded); the same loop
   in this process, frames per second of wall time and of CPU time (the figure a loaded
   machine disturbs least); the annotation's cost per frame from the pairs, and the frames
   ``cv2.VideoCapture`` reads back.

Targets (issue 35): ``aamtrack --help`` <= 0.3 s and ``aamtrack run --help`` <= 0.5 s (median);
on ``videos/single_face.mp4`` (72 frames at 30 fps), ``track --annotate`` writes 72 frames
that OpenCV reads back, at >= 30 frames/s. On a loaded machine the figures grow: the load is
printed with them.
"""

from __future__ import annotations

import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench import options
from bench.targets import Target

AAMTRACK = Path(sys.executable).with_name("aamtrack")
HELP_TARGETS = {("--help",): Target("aamtrack --help, median wall time", "<=", 0.3, "s"),
                ("run", "--help"): Target("aamtrack run --help, median wall time", "<=", 0.5,
                                          "s"),
                ("track", "--help"): None}
ANNOTATE_FPS = Target("track --annotate --csv, median frames/s", ">=", 30.0, "frames/s")
READ_BACK = Target("frames of the annotated video read back", "==", 72)
TARGETS = (*filter(None, HELP_TARGETS.values()), ANNOTATE_FPS, READ_BACK)


def _env() -> dict[str, str]:
    return os.environ | {"OMP_NUM_THREADS": "1", "AAMTRACK_PROGRESS": "0"}


def _wall(argv: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=_env(),
                   check=True)
    return time.perf_counter() - start


def help_rows(runs: int) -> list[tuple[str, float, float, float, Target | None]]:
    times: dict[tuple[str, ...], list[float]] = {args: [] for args in HELP_TARGETS}
    for args in HELP_TARGETS:  # a warm-up each: the file cache, not the first import's
        _wall([str(AAMTRACK), *args])
    for _ in range(runs):
        for args in HELP_TARGETS:
            times[args].append(_wall([str(AAMTRACK), *args]))
    return [("aamtrack " + " ".join(args), statistics.median(t), min(t), max(t),
             HELP_TARGETS[args]) for args, t in times.items()]


def _track(video: Path, classifier: Path, out: Path | None, csv: Path) -> float:
    argv = [str(AAMTRACK), "track", str(video), "--csv", str(csv), "--classifier",
            str(classifier)] + (["--annotate", str(out)] if out else [])
    done = subprocess.run(argv, capture_output=True, text=True, env=_env())
    rate = re.search(r"\(([0-9.]+) frames/s\)", done.stderr)
    if done.returncode != 0 or rate is None:
        raise SystemExit(f"{' '.join(argv)} failed: {done.stderr[-800:]}")
    return float(rate.group(1))


def _frames_read(path: Path) -> int:
    import cv2

    capture, read = cv2.VideoCapture(str(path)), 0
    while capture.read()[0]:
        read += 1
    return read


def _loop(tracker, video: Path, annotator, out: Path | None, csv: Path) -> tuple[float, float]:
    """What ``aamtrack track VIDEO --csv CSV [--annotate OUT]`` does per frame, in this
    process: frames per second of wall time and of CPU time (every thread's)."""
    from aamcore.annotate import VideoWriter
    from aamcore.io.video import video_facts
    from aamcore.results import ResultWriter

    frames, fps = 0, video_facts(video)[1]
    wall, cpu = time.perf_counter(), time.process_time()
    rows = ResultWriter(csv, "csv", 68, tracker.class_names)
    writer = VideoWriter(out, fps) if out else None
    for frame, faces in tracker.process_video_frames(video):
        for face in faces:
            rows.write(face)
        if writer is not None:
            K = tracker.camera_matrix(frame.shape[1], frame.shape[0])
            writer.write(annotator.draw(frame, faces, K))
        frames += 1
    rows.close()
    if writer is not None:
        writer.close()
    return frames / (time.perf_counter() - wall), frames / (time.process_time() - cpu)


def annotate_rows(video: Path, pairs: int) -> dict[str, list[float]]:
    """Frames per second of ``track`` with and without ``--annotate``: the command's own
    figure (whole processes) and, in this process, of wall and of CPU time; and the frames
    OpenCV reads back from the annotated video."""
    from aamcore.annotate import Annotator
    from aamcore.profiles import classifier_path, model_path
    from aamcore.tracker import FaceTracker

    model = model_path()
    classifier = classifier_path(model)
    tracker = FaceTracker(model=model, classifier=classifier)
    got: dict[str, list[float]] = {k: [] for k in (
        "command", "command+annotate", "wall", "wall+annotate", "cpu", "cpu+annotate")}
    with tempfile.TemporaryDirectory() as tmp, Annotator() as annotator:
        out, csv = Path(tmp) / "annotated.mp4", Path(tmp) / "rows.csv"
        _track(video, classifier, None, csv)  # warm-ups: the file cache, the GL context
        _loop(tracker, video, annotator, out, csv)
        for _ in range(pairs):
            got["command"].append(_track(video, classifier, None, csv))
            got["command+annotate"].append(_track(video, classifier, out, csv))
            for key, drawn in (("", None), ("+annotate", out)):
                wall, cpu = _loop(tracker, video, annotator, drawn, csv)
                got["wall" + key].append(wall)
                got["cpu" + key].append(cpu)
        got["read back"] = [float(_frames_read(out))]
    return got


def main(argv: list[str] | None = None) -> int:
    from aamcore.config import data_root

    parser = options.parser(__doc__, __name__)
    parser.add_argument("--runs", type=int, default=9, help="runs of each help (default 9)")
    parser.add_argument("--pairs", type=int, default=3, help="track runs with and without "
                        "--annotate (default 3 each)")
    parser.add_argument("--video", type=Path, help="default: videos/single_face.mp4")
    args = options.parse(parser, argv)
    args.video = args.video or data_root() / "videos" / "single_face.mp4"
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    passed = True
    print(f"\n{'command':<24}{'median s':>10}{'min s':>8}{'max s':>8}{'target s':>10}")
    for name, median, low, high, target in help_rows(args.runs):
        print(f"{name:<24}{median:>10.3f}{low:>8.3f}{high:>8.3f}"
              f"{'' if target is None else f'{target.limit:.1f}':>10}")
        if target is not None:
            passed &= target.check(median)
    got = annotate_rows(args.video, args.pairs)
    read = int(got.pop("read back")[0])
    print(f"\ntrack {args.video.name} --csv [--annotate]: frames/s (median of {args.pairs})")
    for key, values in got.items():
        print(f"  {key:<18}{statistics.median(values):7.1f}   runs "
              + ", ".join(f"{x:.1f}" for x in values))
    cost = {k: 1000 / statistics.median(got[f"{k}+annotate"]) - 1000 / statistics.median(got[k])
            for k in ("wall", "cpu")}
    print(f"  the annotation's cost: {cost['wall']:.1f} ms a frame of wall time, "
          f"{cost['cpu']:.1f} ms of CPU time; frames read back: {read}")
    rate = statistics.median(got["command+annotate"])
    passed &= ANNOTATE_FPS.check(rate)
    passed &= READ_BACK.check(read)
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0 if passed else 1

