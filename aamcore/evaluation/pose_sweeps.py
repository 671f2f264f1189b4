"""Rendered pose sweeps with known poses, tracked by any landmark tracker, cached.

A *sweep* turns the synthetic head (:mod:`aamcore.synth`) through one pose
parameter: yaw (to +-60 degrees by default), pitch, roll (+-40) or distance
(40-120 cm). A *tracker* is any function ``track(frames) -> landmarks`` that
maps a sweep's rendered frames to one (68, 2) iBUG array per frame, or None
where it found no face; its output is cached per tracker name and sweep under
``<cache>/pose_sweeps/`` so that estimators can be compared again without
re-tracking. :func:`tracked_sweeps` renders and tracks the bench's sweeps,
:func:`sequence_sweeps` reads a folder written by ``aamtrack synth`` and
tracks its video; :mod:`aamcore.evaluation.pose_scores` scores estimators on them.
"""

from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from aamcore.config import cache_dir
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.synth.sequence import PoseTruth

Tracker = Callable[[Iterable[np.ndarray]], Sequence[np.ndarray | None]]
"""``track(frames) -> landmarks``: one (68, 2) array or None per BGR frame."""
CACHE_VERSION = 1


@dataclass(frozen=True)
class SweepSpec:
    """One sweep of the synthetic head.

    Attributes
    ----------
    name : str
        Label in tables, e.g. ``"yaw60"``.
    parameter : str
        ``yaw``, ``pitch``, ``roll`` or ``distance``.
    frames : int
    max_angle_deg : float
        Largest angle of an angle sweep.
    """

    name: str
    parameter: str
    frames: int
    max_angle_deg: float = 40.0


DEFAULT_SWEEPS: tuple[SweepSpec, ...] = (
    SweepSpec("yaw60", "yaw", 120, 60.0),
    SweepSpec("pitch40", "pitch", 90, 40.0),
    SweepSpec("roll40", "roll", 90, 40.0),
    SweepSpec("distance", "distance", 90, 40.0),
)
"""The bench's sweeps: yaw to +-60 degrees, pitch and roll to +-40, distance 40-120 cm."""


@dataclass(eq=False)
class TrackedSweep:
    """A rendered sweep with its true poses, exact landmarks and a tracker's landmarks.

    Attributes
    ----------
    spec : SweepSpec
    poses : list of PoseTruth
        True head pose per frame (mm, OpenFace frame).
    exact : (F, 68, 2) array
        Exact image positions of the head's 68 fixed landmark points.
    visible : (F, 68) bool array
        Whether each exact landmark is seen (not hidden by the head).
    landmarks : list of (68, 2) arrays or None
        The tracker's output per frame (empty without a tracker).
    tracker : str
        The tracker's name.
    """

    spec: SweepSpec
    poses: list[PoseTruth]
    exact: np.ndarray
    visible: np.ndarray
    landmarks: list[np.ndarray | None] = field(default_factory=list)
    tracker: str = ""


def cache_path(tracker_name: str, what: str, key: object) -> Path:
    """Where a tracker's landmarks of a sweep or sequence are cached.

    Parameters
    ----------
    tracker_name : str
        Names the tracker: change it when the tracker changes.
    what : str
        The sweep or sequence name, for the file name.
    key : JSON-serialisable
        Everything else the landmarks depend on.
    """
    digest = hashlib.sha1(json.dumps([tracker_name, what, key, CACHE_VERSION]).encode())
    folder = cache_dir() / "pose_sweeps"
    folder.mkdir(parents=True, exist_ok=True)
    safe = "".join(c if c.isalnum() or c in "-_" else "_" for c in tracker_name)
    return folder / f"{safe}-{what}-{digest.hexdigest()[:12]}.npz"


def pack_landmarks(landmarks: Sequence[np.ndarray | None], n: int) -> np.ndarray:
    """Landmarks per frame as one (n, 68, 2) array, NaN where there were none."""
    out = np.full((n, 68, 2), np.nan)
    for i, lm in enumerate(landmarks):
        if lm is not None:
            out[i] = np.asarray(lm, dtype=np.float64).reshape(68, 2)
    return out


def unpack_landmarks(array: np.ndarray) -> list[np.ndarray | None]:
    """The inverse of :func:`pack_landmarks`: None for a frame without landmarks."""
    return [None if np.isnan(a).all() else a for a in array]


def _track(tracker: Tracker, frames: Iterable[np.ndarray], n: int, name: str
           ) -> list[np.ndarray | None]:
    marks = list(tracker(frames))
    if len(marks) != n:
        raise ValueError(f"tracker {name} returned {len(marks)} landmark sets for {n} frames")
    return marks


def tracked_sweeps(
    tracker: Tracker | None,
    tracker_name: str,
    camera: CameraIntrinsics,
    specs: Sequence[SweepSpec] = DEFAULT_SWEEPS,
    use_cache: bool = True,
    log: Callable[[str], None] | None = None,
) -> list[TrackedSweep]:
    """Render each sweep and track it, or read the tracker's landmarks from the cache.

    Parameters
    ----------
    tracker : callable or None
        ``track(frames) -> landmarks``; None renders nothing and gives the
        exact landmarks only (``landmarks`` empty, ``visible`` all True).
    tracker_name : str
        Names the tracker in the cache: change it when the tracker changes.
    camera : CameraIntrinsics
    specs : sequence of SweepSpec
    use_cache : bool
        Read and write ``<cache>/pose_sweeps/``.
    log : callable, optional
        Progress messages.
    """
    from aamcore.synth.head import synth_head
    from aamcore.synth.sequence import default_texture, render_sequence, sweep_poses

    head = synth_head()
    texture = default_texture(head) if tracker is not None else None
    out = []
    for spec in specs:
        poses = sweep_poses(spec.parameter, spec.frames, spec.max_angle_deg)
        exact = np.array([camera.project(head.landmarks_3d, p.R, p.T) for p in poses])
        sweep = TrackedSweep(spec, poses, exact, np.ones(exact.shape[:2], bool),
                             tracker=tracker_name)
        out.append(sweep)
        if tracker is None or texture is None:
            continue
        key = [spec.parameter, spec.frames, spec.max_angle_deg, camera.K.tolist(),
               camera.width, camera.height, texture.source]
        path = cache_path(tracker_name, spec.name, key)
        if use_cache and path.is_file():
            with np.load(path) as data:
                sweep.visible, sweep.landmarks = data["visible"], unpack_landmarks(
                    data["landmarks"])
            continue
        started = time.perf_counter()
        rendered = list(render_sequence(poses, camera, head, texture))
        sweep.visible = np.array([v for _, _, v in rendered])
        sweep.landmarks = _track(tracker, (image for image, _, _ in rendered), len(poses),
                                 tracker_name)
        if use_cache:
            np.savez_compressed(path, landmarks=pack_landmarks(sweep.landmarks, len(poses)),
                                visible=sweep.visible)
        if log:
            log(f"{spec.name}: rendered and tracked {len(poses)} frames with {tracker_name} "
                f"in {time.perf_counter() - started:.0f} s")
    return out


def _sequence_landmarks(folder: Path, video: str, n: int, tracker: Tracker | None,
                        tracker_name: str, use_cache: bool) -> list[np.ndarray | None]:
    """The tracker's landmarks on a sequence's video, through the cache."""
    from aamcore.io.video import video_frames

    if tracker is None:
        return []
    summary = (folder / "sequence.json").read_bytes()
    path = cache_path(tracker_name, folder.name, hashlib.sha1(summary).hexdigest())
    if use_cache and path.is_file():
        with np.load(path) as data:
            return unpack_landmarks(data["landmarks"])
    marks = _track(tracker, video_frames(folder / video), n, tracker_name)
    if use_cache:
        np.savez_compressed(path, landmarks=pack_landmarks(marks, n))
    return marks


def sequence_sweeps(
    folder: str | Path, tracker: Tracker | None, tracker_name: str, use_cache: bool = True
) -> tuple[list[TrackedSweep], CameraIntrinsics]:
    """The sweeps of a folder written by ``aamtrack synth``, tracked on its video.

    Frames are grouped by their ``sweep`` field (``yaw``, ``pitch``, ...); the
    largest angle is read from ``sequence.json``. The video is mp4v-compressed,
    as a camera's would be.

    Parameters
    ----------
    folder : path
    tracker : callable or None
        Runs on the video's frames; None gives no tracked landmarks.
    tracker_name : str
    use_cache : bool
        Keep the tracker's landmarks under ``<cache>/pose_sweeps/``, keyed by
        the sequence's ``sequence.json``.

    Returns
    -------
    sweeps : list of TrackedSweep
        ``exact`` holds the sequence's recorded landmarks.
    camera : CameraIntrinsics
        The sequence's intrinsics.

    Raises
    ------
    ValueError
        If the folder is not a complete synth sequence.
    """
    from aamcore.synth.sequence import load_sequence

    folder = Path(folder)
    summary, records = load_sequence(folder)
    intr = summary["intrinsics"]
    camera = CameraIntrinsics(np.array(intr["camera_matrix"]),
                              np.array(intr["distortion_coefficients"]),
                              intr["image_width"], intr["image_height"], str(folder))
    marks = _sequence_landmarks(folder, summary["video"], len(records), tracker, tracker_name,
                                use_cache)
    max_angle = float(summary.get("max_angle_deg", 40.0))
    names = [r.get("sweep", "") or "all" for r in records]
    out: list[TrackedSweep] = []
    for name in dict.fromkeys(names):
        rows = [i for i, n in enumerate(names) if n == name]
        poses = [PoseTruth(np.array(records[i]["R"]), np.array(records[i]["T"]), name)
                 for i in rows]
        label = f"seq-{name}{max_angle:g}" if name in ("yaw", "pitch", "roll") else f"seq-{name}"
        spec = SweepSpec(label, name, len(rows), max_angle)
        out.append(TrackedSweep(spec, poses, np.array([records[i]["landmarks"] for i in rows]),
                                np.array([records[i]["visible"] for i in rows]),
                                [marks[i] for i in rows] if marks else [], tracker_name))
    return out, camera
