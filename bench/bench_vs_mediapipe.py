"""FaceTracker against MediaPipe's Face Mesh, per frame, in one process, and FaceTracker's time
stage by stage.

Run: ``python -m bench vs-mediapipe [--rounds 5] [--model FILE]``; MediaPipe is the peer,
installed with the ``[peers]`` extra: ``pip install -e '.[peers]' && pip install --no-deps
mediapipe==0.10.14`` (README, Install); without it the bench says so and exits 2.

The frames of ``videos/single_face.mp4`` (640x360) are decoded once, up front. Then, in this
process and thread, in turn, ``--rounds`` times: MediaPipe's legacy Face Mesh solution
(``mediapipe.solutions.face_mesh.FaceMesh(static_image_mode=False, max_num_faces=1,
refine_landmarks=False)``, 468 points, tracking from frame to frame; it gets the RGB frame,
converted outside its timing), made afresh each round; ``FaceTracker()`` with its defaults
(landmarks, appearance, occlusion flags, pose, expression), started afresh each round
(:meth:`~aamcore.tracker.FaceTracker.reset`); and ``FaceTracker`` again with each of its
stages timed (the fit, pose and expression operators called through a timer), which gives
the pose and expression per face and the glue: ``process_faces`` less its stages (the frame
reference, the results). OpenCV runs in the calling thread (``cv2.setNumThreads(1)``);
MediaPipe's calculator graph runs in threads of its own, the caller waiting. Each figure is
the median wall time of a frame in a round, the best round's; the CPU time of the whole
process per frame and the load average are printed beside it. The ratio that counts is the
one of the same run.

Targets (issue 47): FaceTracker <= 1.2x MediaPipe in the same run and <= 2.5 ms a frame;
pose <= 0.3 ms and expression <= 0.8 ms a face; glue <= 0.2 ms a frame.
"""

from __future__ import annotations

import os
import time
import warnings
from collections.abc import Callable
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2
import numpy as np

from bench import options
from bench.targets import Target

RATIO = Target("FaceTracker() / MediaPipe Face Mesh, median ms a frame, same run", "<=", 1.2,
               "x")
TRACKER_MS = Target("FaceTracker() median a frame", "<=", 2.5, "ms")
POSE_MS = Target("pose stage per face (median)", "<=", 0.3, "ms")
EXPRESSION_MS = Target("expression stage per face (median)", "<=", 0.8, "ms")
GLUE_MS = Target("glue: process_faces less its stages (median)", "<=", 0.2, "ms")
TARGETS = (RATIO, TRACKER_MS, POSE_MS, EXPRESSION_MS, GLUE_MS)
CLIP = "videos/single_face.mp4"
INSTALL = ("pip install -e '.[peers]' && pip install --no-deps mediapipe==0.10.14 (its own "
           "dependencies would replace the project's OpenCV with 5.x: pyproject.toml)")


class Timed:
    """A stage operator called through a wall-clock timer: the seconds of its last call."""

    def __init__(self, stage: Callable[..., Any]) -> None:
        self.stage = stage
        self.seconds = 0.0

    def __call__(self, *args: Any) -> Any:
        t0 = time.perf_counter()
        out = self.stage(*args)
        self.seconds = time.perf_counter() - t0
        return out

    def __getattr__(self, name: str) -> Any:
        return getattr(self.stage, name)


def mediapipe_pass(mp_face_mesh: Any, rgb: list[np.ndarray]) -> dict[str, Any]:
    """One pass of a fresh Face Mesh over the frames: ms per frame, frames with a face, CPU."""
    mesh = mp_face_mesh.FaceMesh(static_image_mode=False, max_num_faces=1,
                                 refine_landmarks=False)
    ms, found = [], 0
    cpu0 = time.process_time()
    try:
        for frame in rgb:
            t0 = time.perf_counter()
            out = mesh.process(frame)
            ms.append(1e3 * (time.perf_counter() - t0))
            found += out.multi_face_landmarks is not None
    finally:
        cpu = time.process_time() - cpu0
        mesh.close()
    return {"ms": np.array(ms), "found": found, "cpu_ms": 1e3 * cpu / len(rgb)}


def tracker_pass(tracker: Any, frames: list[np.ndarray], fps: float) -> dict[str, Any]:
    """One pass of ``tracker`` (started afresh) over the frames: ms per frame, frames with a
    successful fit, CPU; with its stages behind :class:`Timed`, the ms of each."""
    tracker.reset()
    tracker.frames = 0
    stages = {name: getattr(tracker, name) for name in ("fit", "pose", "expression")
              if isinstance(getattr(tracker, name), Timed)}
    ms, found, faces = [], 0, []
    parts: dict[str, list[float]] = {name: [] for name in stages}
    cpu0 = time.process_time()
    for k, frame in enumerate(frames):
        t0 = time.perf_counter()
        results = tracker.process_faces(frame, k / fps)
        ms.append(1e3 * (time.perf_counter() - t0))
        found += results[0].success
        faces.append(sum(len(r.landmarks) > 0 for r in results))
        for name, stage in stages.items():
            parts[name].append(1e3 * stage.seconds)
    cpu = time.process_time() - cpu0
    out = {"ms": np.array(ms), "found": found, "faces": np.array(faces),
           "cpu_ms": 1e3 * cpu / len(frames)}
    out.update({name: np.array(v) for name, v in parts.items()})
    return out


def breakdown(run: dict[str, Any]) -> dict[str, float]:
    """Median ms of the fit a frame, pose and expression a face (frames with a face), and the
    glue a frame."""
    with_face = run["faces"] > 0
    n = np.maximum(run["faces"], 1)
    glue = run["ms"] - sum(run[name] for name in ("fit", "pose", "expression") if name in run)
    out = {"fit": float(np.median(run["fit"])), "glue": float(np.median(glue))}
    for name in ("pose", "expression"):
        if name in run:
            per_face = (run[name] / n)[with_face]
            out[name] = float(np.median(per_face)) if per_face.size else float("nan")
    return out


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__, model=True)
    parser.add_argument("--rounds", type=int, default=5,
                        help="rounds of MediaPipe, FaceTracker and FaceTracker by stage in "
                             "turn; each figure is the best round's median (default 5)")
    parser.add_argument("--frames", type=int, default=0,
                        help="the clip's first N frames only (0: all)")
    args = options.parse(parser, argv)
    if args.rounds < 1:
        parser.error("--rounds must be at least 1")
    # protobuf's deprecation note at MediaPipe's every first result
    warnings.filterwarnings("ignore", "SymbolDatabase.GetPrototype", UserWarning)
    try:
        import mediapipe
    except ImportError as exc:
        print(f"python -m bench vs-mediapipe: MediaPipe is not installed ({exc}); install "
              f"the peers: {INSTALL}")
        return 2
    mp_face_mesh = mediapipe.solutions.face_mesh

    from aamcore.config import data_root
    from aamcore.io.video import video_facts, video_frames
    from aamcore.tracker import FaceTracker

    cv2.setNumThreads(1)  # one thread: OpenCV's own pool would lend FaceTracker a second core
    path = data_root() / CLIP
    frames = video_frames(path)
    if args.frames:
        frames = frames[:args.frames]
    fps = video_facts(path)[1] or 30.0
    rgb = [cv2.cvtColor(f, cv2.COLOR_BGR2RGB) for f in frames]
    model = options.model_path(args) if args.model is not None else None
    plain = FaceTracker(model=model)
    staged = FaceTracker(model=model)
    for name in ("fit", "pose", "expression"):
        stage = getattr(staged, name)
        if stage is not None:
            setattr(staged, name, Timed(stage))
    h, w = frames[0].shape[:2]
    print(f"{CLIP}: {len(frames)} frames {w}x{h} at {fps:g} fps; mediapipe "
          f"{mediapipe.__version__}, numpy {np.__version__}, OpenCV {cv2.__version__}; "
          f"OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS')}; "
          f"expression {'on' if plain.expression is not None else 'off'}")
    print(f"\n{'round':<6}{'system':<22}{'median ms':>10}{'p90 ms':>8}{'CPU ms/frame':>13}"
          f"{'faces':>7}{'load':>6}")
    runs: dict[str, list[dict[str, Any]]] = {"mediapipe": [], "tracker": [], "staged": []}
    for r in range(args.rounds):
        for name, go in (("mediapipe", lambda: mediapipe_pass(mp_face_mesh, rgb)),
                         ("tracker", lambda: tracker_pass(plain, frames, fps)),
                         ("staged", lambda: tracker_pass(staged, frames, fps))):
            run = go()
            runs[name].append(run)
            label = {"mediapipe": "MediaPipe Face Mesh", "tracker": "FaceTracker()",
                     "staged": "FaceTracker() by stage"}[name]
            print(f"{r + 1:<6}{label:<22}{np.median(run['ms']):>10.3f}"
                  f"{np.percentile(run['ms'], 90):>8.3f}{run['cpu_ms']:>13.3f}"
                  f"{run['found']:>4}/{len(frames):<3}{os.getloadavg()[0]:>5.1f}", flush=True)
    plain.close()
    staged.close()
    best = {name: min(float(np.median(run["ms"])) for run in rs) for name, rs in runs.items()}
    ratio = best["tracker"] / best["mediapipe"]
    print(f"\nbest medians: MediaPipe {best['mediapipe']:.3f} ms, FaceTracker "
          f"{best['tracker']:.3f} ms: {ratio:.2f}x MediaPipe")
    parts = [breakdown(run) for run in runs["staged"]]
    names = [n for n in ("fit", "pose", "expression", "glue") if n in parts[0]]
    stage_best = {n: min(p[n] for p in parts) for n in names}
    print("FaceTracker by stage, best round's median ms: "
          + ", ".join(f"{n} {stage_best[n]:.3f}{'' if n in ('fit', 'glue') else ' a face'}"
                      for n in names)
          + f" (process {best['staged']:.3f})")
    detail = f"load {os.getloadavg()[0]:.1f}, best of {args.rounds}"
    RATIO.check(ratio, f"{best['tracker']:.3f} / {best['mediapipe']:.3f} ms, {detail}")
    TRACKER_MS.check(best["tracker"], detail)
    if "pose" in stage_best:
        POSE_MS.check(stage_best["pose"], detail)
    if "expression" in stage_best:
        EXPRESSION_MS.check(stage_best["expression"], detail)
    GLUE_MS.check(stage_best["glue"], detail)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
