"""Ground-truth sequences: known head poses, exact landmarks, rendered video.

A sequence sweeps one pose parameter at a time, as in the thesis's
experiments (figure 14.4): yaw, pitch and roll from 0 to +40, to -40 and back
to 0 degrees at 60 cm (or to another largest angle), and the distance from 60
cm out to 120, in to 40 and back to 60.
``synthesize`` writes ``video.mp4`` (mp4v), one JSON file per frame under
``frames/`` (exact 2D landmarks, their visibility, R, T, angles and the
intrinsics) and ``sequence.json`` (intrinsics, the head's exact 3D landmarks,
the texture's source).
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from aamcore.config import data_root
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.rotation import rotation_from_rpy, rpy_from_rotation
from aamcore.synth.head import SynthHead, synth_head
from aamcore.synth.renderer import HeadRenderer
from aamcore.synth.texture import FaceTexture, face_texture, frontal_lfpw_photo

SWEEPS = ("yaw", "pitch", "roll", "distance")
MAX_ANGLE_DEG = 40.0
BASE_DISTANCE_MM = 600.0
DISTANCE_RANGE_MM = (400.0, 1200.0)


@dataclass(frozen=True, eq=False)
class PoseTruth:
    """A known head pose: ``X_cam = R @ X_head + T``.

    Attributes
    ----------
    R : (3, 3) array
    T : (3,) array
        mm.
    sweep : str
        Which sweep the frame belongs to.
    """

    R: np.ndarray
    T: np.ndarray
    sweep: str = ""

    def to_json(self) -> dict[str, Any]:
        """R, T, roll-pitch-yaw (deg) and distance (mm) as plain lists and floats."""
        rpy = rpy_from_rotation(self.R)
        return {"R": self.R.tolist(), "T": self.T.tolist(), "rpy_deg": rpy._asdict(),
                "distance_mm": float(np.linalg.norm(self.T)), "sweep": self.sweep}


def sweep_poses(
    sweep: str, frames: int, max_angle_deg: float = MAX_ANGLE_DEG
) -> list[PoseTruth]:
    """Poses of one sweep (``yaw``, ``pitch``, ``roll``, ``distance``) or of ``all`` four.

    ``all`` gives the four sweeps one after the other, sharing ``frames``. An
    angle sweep goes from 0 to ``+max_angle_deg``, to ``-max_angle_deg`` and
    back to 0 (default 40, the thesis's range).

    Raises
    ------
    ValueError
        For an unknown sweep, fewer frames than sweeps or an angle outside (0, 90).
    """
    if not 0.0 < max_angle_deg < 90.0:
        raise ValueError(f"max_angle_deg must lie in (0, 90), got {max_angle_deg}")
    if sweep == "all":
        if frames < len(SWEEPS):
            raise ValueError(f"sweep 'all' needs at least {len(SWEEPS)} frames, got {frames}")
        counts = np.diff(np.linspace(0, frames, len(SWEEPS) + 1).round().astype(int))
        return [p for name, n in zip(SWEEPS, counts, strict=True)
                for p in sweep_poses(name, n, max_angle_deg)]
    if sweep not in SWEEPS:
        raise ValueError(f"unknown sweep {sweep!r}; choose from {SWEEPS + ('all',)}")
    if frames < 1:
        raise ValueError(f"frames must be positive, got {frames}")
    phase = 2.0 * np.pi * np.arange(frames) / frames
    poses = []
    for t in phase:
        angles = {"roll": 0.0, "pitch": 0.0, "yaw": 0.0}
        distance = BASE_DISTANCE_MM
        if sweep == "distance":  # 60 cm out to 120, in to 40, back to 60
            near, far = DISTANCE_RANGE_MM
            reach = far - BASE_DISTANCE_MM if np.sin(t) > 0 else BASE_DISTANCE_MM - near
            distance = BASE_DISTANCE_MM + reach * np.sin(t)
        else:
            angles[sweep] = max_angle_deg * np.sin(t)
        R = rotation_from_rpy(angles["roll"], angles["pitch"], angles["yaw"])
        poses.append(PoseTruth(R, np.array([0.0, 0.0, distance]), sweep))
    return poses


def exact_landmarks(
    head: SynthHead, poses: list[PoseTruth], camera: CameraIntrinsics
) -> list[np.ndarray]:
    """The 68 landmarks' pixel positions under each pose, each (68, 2)."""
    points = head.landmarks_3d
    return [camera.project(points, p.R, p.T) for p in poses]


def annotated_landmarks(
    head: SynthHead, poses: list[PoseTruth], camera: CameraIntrinsics
) -> list[np.ndarray]:
    """The 68 landmarks as a 300-W annotator marks them, under each pose, each (68, 2).

    The 51 inner points are the exact images of the head's fixed points (also
    when hidden: a guess at a hidden point is where it would be); the 17 jaw
    points lie on the head's outline as seen, found by landmark marching on
    the head mesh (:mod:`aamcore.pose.contour`): on the far side of a turned
    head they move onto the cheek's occluding contour instead of staying on
    hidden skin.
    """
    outline = head.outline_model()
    points = head.landmarks_3d
    out = []
    for p in poses:
        uv = camera.project(points, p.R, p.T)
        jaw, _, _ = outline.silhouette(p.R, p.T, camera.K)
        uv[outline.landmarks] = camera.project(jaw, p.R, p.T)
        out.append(uv)
    return out


def default_texture(head: SynthHead) -> FaceTexture:
    """A texture from the most frontal of the first LFPW photos in the data folder."""
    photo, landmarks, name = frontal_lfpw_photo(data_root() / "lfpw" / "trainset")
    return face_texture(head, photo, landmarks, f"lfpw/trainset/{name}")


def render_sequence(
    poses: list[PoseTruth],
    camera: CameraIntrinsics,
    head: SynthHead | None = None,
    texture: FaceTexture | None = None,
) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Render each pose: yields (BGR image (H, W, 3), landmarks (68, 2), visible (68,) bool).

    A landmark is visible when the rendered surface at its pixel is no more
    than 3 mm in front of it. The GL context lives in the calling thread for
    the duration of the iteration.
    """
    head = head or synth_head()
    texture = texture or default_texture(head)
    points = head.landmarks_3d
    with HeadRenderer(head, texture, camera) as renderer:
        for pose in poses:
            frame = renderer.render(pose.R, pose.T)
            uv = camera.project(points, pose.R, pose.T)
            z = (points @ pose.R.T + pose.T)[:, 2]
            px = np.clip(np.round(uv).astype(int), 0, [camera.width - 1, camera.height - 1])
            visible = z <= frame.depth[px[:, 1], px[:, 0]] + 3.0
            yield frame.image, uv, visible


def _write_frames(
    out: Path,
    poses: list[PoseTruth],
    camera: CameraIntrinsics,
    head: SynthHead,
    texture: FaceTexture,
    fps: float,
) -> Path:
    """Render ``poses`` into ``out/video.mp4`` and ``out/frames/NNNNNN.json``; returns the video.

    Raises
    ------
    OSError
        If the video cannot be written.
    """
    (out / "frames").mkdir(parents=True, exist_ok=True)
    video_path = out / "video.mp4"
    writer = cv2.VideoWriter(str(video_path), cv2.VideoWriter_fourcc(*"mp4v"), fps,
                             (camera.width, camera.height))
    if not writer.isOpened():
        raise OSError(f"{video_path}: cannot open an mp4v video writer")
    intrinsics = camera.to_json()
    try:
        rendered = render_sequence(poses, camera, head, texture)
        for i, (pose, (image, uv, visible)) in enumerate(zip(poses, rendered, strict=True)):
            writer.write(image)
            record = {"frame": i, "landmarks": uv.tolist(), "visible": visible.tolist(),
                      "scheme": "ibug68", **pose.to_json(), "intrinsics": intrinsics}
            (out / "frames" / f"{i:06d}.json").write_text(json.dumps(record))
    finally:
        writer.release()
    return video_path


def synthesize(
    out_dir: str | Path,
    frames: int = 120,
    sweep: str = "all",
    camera: CameraIntrinsics | None = None,
    texture: FaceTexture | None = None,
    fps: float = 30.0,
    max_angle_deg: float = MAX_ANGLE_DEG,
) -> Path:
    """Write a ground-truth sequence to ``out_dir``; returns the ``sequence.json`` path.

    Parameters
    ----------
    out_dir : path
        Created if needed; ``video.mp4``, ``frames/NNNNNN.json`` and
        ``sequence.json`` are written (over any earlier ones).
    frames : int
        Number of frames.
    sweep : str
        ``yaw``, ``pitch``, ``roll``, ``distance`` or ``all``.
    camera : CameraIntrinsics, optional
        Default 640x480 with a 60 degree horizontal field of view.
    texture : FaceTexture, optional
        Default: from an LFPW photo (:func:`default_texture`).
    fps : float
        Frame rate written in the video.
    max_angle_deg : float
        Largest angle of the angle sweeps, degrees (default 40).

    Raises
    ------
    ValueError
        For a bad sweep, frame count or angle; OSError if the video cannot be written.
    """
    out = Path(out_dir)
    poses = sweep_poses(sweep, frames, max_angle_deg)
    camera = camera or CameraIntrinsics.from_fov(640, 480, 60.0)
    head = synth_head()
    texture = texture or default_texture(head)
    video_path = _write_frames(out, poses, camera, head, texture, fps)
    summary = {
        "frames": frames, "sweep": sweep, "fps": fps, "max_angle_deg": max_angle_deg,
        "video": video_path.name,
        "intrinsics": camera.to_json(), "scheme": "ibug68",
        "model_points_mm": head.landmarks_3d.tolist(),
        "mesh": "MediaPipe canonical face mesh in the openface_mean68 frame (mm, OpenCV axes)",
        "texture_source": texture.source,
    }
    path = out / "sequence.json"
    path.write_text(json.dumps(summary, indent=1))
    return path


def load_sequence(folder: str | Path) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """Read a folder written by :func:`synthesize`: (summary, per-frame records).

    Raises
    ------
    ValueError
        Naming the file, if ``sequence.json`` or a frame file is missing or malformed.
    """
    folder = Path(folder)
    try:
        summary = json.loads((folder / "sequence.json").read_text())
        records = [json.loads((folder / "frames" / f"{i:06d}.json").read_text())
                   for i in range(int(summary["frames"]))]
    except (OSError, json.JSONDecodeError, KeyError) as exc:
        raise ValueError(f"{folder}: not a complete synth sequence ({exc})") from exc
    return summary, records
