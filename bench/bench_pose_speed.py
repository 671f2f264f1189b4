"""Bench: the head pose's per-face work alone, as the stack runs it, in thread CPU time.

Run: ``python -m bench pose-speed [--passes 7] [--vs CHECKOUT]``

The landmarks come first, outside any timing: the default model's ``FaceTracker`` (without
expression) on ``videos/single_face.mp4`` (the landmarks as served: smoothed, with each fit's
verdict), and an annotated yaw sweep of the synthetic head, -60 to +60 degrees in 120 frames
at 30 frames/s, with 2 % of the eye-corner distance of noise (twice that on the jaw). Then
each stream goes through what the pose stage does per face, :class:`HeadPoseTracker`
(the default estimator with smoothing: contour fit, POSIT where it starts cold, smoothing,
reliability), ``--passes`` times, each pass a fresh tracker; every call is timed in the
thread's CPU time (what a neighbour's load disturbs least) and in wall time. The row
"cold" times :meth:`HeadPoseEstimator.estimate` after a :meth:`~HeadPoseEstimator.reset`
each frame: every frame from POSIT's answer, with no smoothing.

``--vs CHECKOUT`` times the same streams with another checkout's code (its ``.venv``, in
a child process, in turn with this checkout's, pass block after pass block) and gives the
ratio of the medians and how far apart the two checkouts' poses are (degrees between
rotations, mm between translations, and how many frames' reliability differs).

Target (issue 47 item 1): the stage's per-face work <= 0.3 ms on ``single_face.mp4``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bench import options
from bench.targets import Target

HERE = Path(__file__).resolve().parents[1]
PER_FACE = Target("pose per face on single_face.mp4 (median thread CPU, HeadPoseTracker with "
                  "smoothing)", "<=", 0.3, "ms")
TARGETS = (PER_FACE,)
YAW_FRAMES, FPS = 120, 30.0


def tracked_video(path: Path) -> dict[str, np.ndarray]:
    """The served landmarks (F, 68, 2), fit verdicts, timestamps and frame size of a video."""
    from aamcore.tracker import FaceTracker

    marks, ok, stamps, size = [], [], [], (0, 0)
    with FaceTracker(classifier=False) as tracker:
        for frame, faces in tracker.process_video_frames(path):
            size = frame.shape[:2]
            face = faces[0]
            if len(face.landmarks):
                marks.append(face.landmarks)
                ok.append(face.success)
                stamps.append(face.timestamp)
    return {"landmarks": np.array(marks), "ok": np.array(ok), "t": np.array(stamps),
            "size": np.array([size[1], size[0]]), "fov": np.array(np.nan)}


def yaw_sweep(seed: int = 0) -> dict[str, np.ndarray]:
    """Annotated landmarks of the synthetic head turning from -60 to +60 degrees, with noise."""
    from aamcore.pose.intrinsics import CameraIntrinsics
    from aamcore.pose.rotation import rotation_from_rpy
    from aamcore.synth.head import synth_head
    from aamcore.synth.sequence import PoseTruth, annotated_landmarks

    camera = CameraIntrinsics.from_fov(640, 480, 60.0)
    poses = [PoseTruth(rotation_from_rpy(0.0, 0.0, yaw), np.array([0.0, 0.0, 600.0]))
             for yaw in np.linspace(-60.0, 60.0, YAW_FRAMES)]
    rng = np.random.default_rng(seed)
    marks = []
    for uv in annotated_landmarks(synth_head(), poses, camera):
        sd = np.full((68, 1), 0.02 * float(np.linalg.norm(uv[36] - uv[45])))
        sd[:17] *= 2.0
        marks.append(uv + rng.standard_normal(uv.shape) * sd)
    return {"landmarks": np.array(marks), "ok": np.ones(YAW_FRAMES, bool),
            "t": np.arange(YAW_FRAMES) / FPS, "size": np.array([640, 480]), "fov": np.array(60.0)}


def time_stream(stream: dict[str, np.ndarray], passes: int, cold: bool
                ) -> tuple[list[float], list[float], np.ndarray]:
    """CPU and wall ms of every call over ``passes`` passes, and the last pass's poses
    (F, 13): R (9), T (3) and reliable (NaN where no pose)."""
    from aamcore.pose.errors import PoseError
    from aamcore.pose.estimator import Cameras, HeadPoseEstimator, HeadPoseTracker

    width, height = (int(v) for v in stream["size"])
    fov = float(stream["fov"])
    cpu, wall = [], []
    poses = np.full((len(stream["landmarks"]), 13), np.nan)
    for _ in range(passes):
        cameras = Cameras(fov) if np.isfinite(fov) else Cameras()
        tracker = HeadPoseTracker(HeadPoseEstimator(cameras), smooth=True)
        estimator = tracker.estimator
        for k, (marks, ok, t) in enumerate(zip(stream["landmarks"], stream["ok"], stream["t"],
                                               strict=True)):
            if cold:
                estimator.reset()
            c0, w0 = time.thread_time_ns(), time.perf_counter_ns()
            try:
                pose = (estimator.estimate(marks, width, height) if cold else
                        tracker.update(marks, width, height, float(t), not ok))
            except PoseError:
                pose = None
            cpu.append((time.thread_time_ns() - c0) / 1e6)
            wall.append((time.perf_counter_ns() - w0) / 1e6)
            if pose is not None:
                e = pose.estimate
                poses[k] = [*e.R.ravel(), *e.T, float(e.reliable)]
    return cpu, wall, poses


def worker(streams_file: Path, passes: int, out: Path) -> None:
    """Time every stream in both modes; write the figures and poses to ``out`` (.npz)."""
    data = np.load(streams_file)
    names = sorted({key.split("/")[0] for key in data.files})
    results: dict[str, np.ndarray] = {}
    for name in names:
        stream = {key.split("/")[1]: data[key] for key in data.files if key.startswith(name)}
        for mode in ("tracker", "cold"):
            cpu, wall, poses = time_stream(stream, passes, mode == "cold")
            results[f"{name}/{mode}/cpu"] = np.array(cpu)
            results[f"{name}/{mode}/wall"] = np.array(wall)
            results[f"{name}/{mode}/poses"] = poses
    np.savez(out, **results)


def run_worker(checkout: Path, streams_file: Path, passes: int) -> dict[str, np.ndarray]:
    """The worker of this file with ``checkout``'s code and Python, in a child process."""
    with tempfile.TemporaryDirectory(prefix="bench-pose-") as folder:
        out = Path(folder) / "out.npz"
        # its aamcore first; this checkout's bench package after it (a regular package is
        # found before a folder of the same name without __init__.py, as older checkouts have)
        env = os.environ | {"PYTHONPATH": os.pathsep.join(map(str, (checkout, HERE))),
                            "OMP_NUM_THREADS": "1"}
        subprocess.run([str(checkout / ".venv" / "bin" / "python"), __file__,
                        str(streams_file), str(passes), str(out)],
                       cwd=checkout, env=env, check=True)
        with np.load(out) as data:
            return {key: data[key] for key in data.files}


def angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Degrees between rotations given as rows of 9 (F, 9)."""
    Ra, Rb = a.reshape(-1, 3, 3), b.reshape(-1, 3, 3)
    cos = (np.einsum("fij,fij->f", Ra, Rb) - 1.0) / 2.0
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def report(runs: dict[Path, list[dict[str, np.ndarray]]], names: list[str]) -> float:
    """Print the table (and the comparison with --vs); this checkout's tracker median ms on
    the video."""
    mine = HERE
    print(f"\n{'checkout':<24}{'stream':<22}{'mode':<9}{'cpu median':>11}{'p95':>8}"
          f"{'wall median':>13}{'calls':>7}")
    medians: dict[tuple[Path, str, str], float] = {}
    for checkout, blocks in runs.items():
        for name in names:
            for mode in ("tracker", "cold"):
                cpu = np.concatenate([b[f"{name}/{mode}/cpu"] for b in blocks])
                wall = np.concatenate([b[f"{name}/{mode}/wall"] for b in blocks])
                medians[checkout, name, mode] = float(np.median(cpu))
                print(f"{str(checkout)[-23:]:<24}{name:<22}{mode:<9}{np.median(cpu):11.3f}"
                      f"{np.percentile(cpu, 95):8.3f}{np.median(wall):13.3f}{len(cpu):7d}")
    others = [c for c in runs if c != mine]
    for other in others:
        print(f"\nthis checkout against {other} (ms per face, CPU; poses of the last pass)")
        for name in names:
            for mode in ("tracker", "cold"):
                key = f"{name}/{mode}/poses"
                a, b = runs[mine][-1][key], runs[other][-1][key]
                both = np.isfinite(a[:, 0]) & np.isfinite(b[:, 0])
                deg = angle_deg(a[both, :9], b[both, :9])
                mm = np.linalg.norm(a[both, 9:12] - b[both, 9:12], axis=1)
                flips = int(np.sum(a[both, 12] != b[both, 12]))
                ratio = medians[other, name, mode] / medians[mine, name, mode]
                print(f"  {name:<22}{mode:<9}{ratio:5.2f}x faster; poses apart median "
                      f"{np.median(deg):.3f} deg, max {deg.max():.3f} deg, max "
                      f"{mm.max():.2f} mm; reliability differs on {flips} of {both.sum()} "
                      f"frames; pose on {int(np.isfinite(a[:, 0]).sum())} / "
                      f"{int(np.isfinite(b[:, 0]).sum())} frames")
    return medians[mine, names[0], "tracker"]


def main(argv: list[str] | None = None) -> int:

    parser = options.parser(__doc__, __name__)
    parser.add_argument("--passes", type=int, default=7, help="passes over each stream")
    parser.add_argument("--blocks", type=int, default=3,
                        help="blocks of passes per checkout, run in turn")
    parser.add_argument("--video", type=Path, help="default: videos/single_face.mp4")
    parser.add_argument("--vs", type=Path, help="another checkout to time in turn")
    args = options.parse(parser, argv)
    from aamcore.config import data_root

    video = args.video or data_root() / "videos" / "single_face.mp4"
    streams = {f"video {video.name}": tracked_video(video), "sweep yaw +-60": yaw_sweep()}
    names = list(streams)
    load = os.getloadavg()[0]
    checkouts = [HERE] + ([args.vs.resolve()] if args.vs else [])
    runs: dict[Path, list[dict[str, np.ndarray]]] = {c: [] for c in checkouts}
    with tempfile.TemporaryDirectory(prefix="bench-pose-") as folder:
        streams_file = Path(folder) / "streams.npz"
        np.savez(streams_file, **{f"{name}/{key}": value for name, stream in streams.items()
                                  for key, value in stream.items()})
        for k in range(args.blocks):
            for checkout in checkouts if k % 2 == 0 else checkouts[::-1]:
                runs[checkout].append(run_worker(checkout, streams_file, args.passes))
    print(f"pose per face, {len(streams[names[0]]['landmarks'])} frames of {video.name} and "
          f"{YAW_FRAMES} of the yaw sweep, {args.blocks} x {args.passes} passes "
          f"(load {load:.1f} -> {os.getloadavg()[0]:.1f})")
    ms = report(runs, names)
    return 0 if PER_FACE.check(ms, video.name) else 1


if __name__ == "__main__":  # the --vs worker: this file with another checkout's code
    worker(Path(sys.argv[1]), int(sys.argv[2]), Path(sys.argv[3]))
