"""The head pose of occluded faces for ``bench_occlusion.py``: from every fitted landmark,
and from those the fit does not flag occluded only, each against the pose of the frame's
annotated landmarks (the same estimator, the default ``contour``)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from aamcore.pose import IntrinsicsError, PoseError
from aamcore.pose.estimator import HeadPoseEstimator

WAYS = ("all landmarks", "visible landmarks only")


def angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    """The angle (degrees) of the rotation between rotations ``a`` and ``b`` (3, 3)."""
    cos = (np.trace(a.T @ b) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))


@dataclass
class PoseErrors:
    """Angles between each way's pose and the annotated landmarks' pose, per kind of frame
    (``occluded``: an occluder hides at least one landmark; ``clean``), and the frames
    where a way gave no pose."""

    errors: dict[tuple[str, str], list[float]] = field(default_factory=dict)
    missing: dict[tuple[str, str], int] = field(default_factory=dict)

    def add(self, other: PoseErrors) -> None:
        for key, values in other.errors.items():
            self.errors.setdefault(key, []).extend(values)
        for key, n in other.missing.items():
            self.missing[key] = self.missing.get(key, 0) + n

    def rows(self) -> list[str]:
        out = []
        for frames in ("occluded", "clean"):
            for way in WAYS:
                e = np.array(self.errors.get((frames, way), []))
                missing = self.missing.get((frames, way), 0)
                cells = (f"{np.median(e):6.2f} {np.percentile(e, 90):6.2f} {np.mean(e > 10):6.1%}"
                         if e.size else "     -      -      -")
                out.append(f"| {frames} | {way} | {e.size} | {cells} | {missing} |")
        return out


class PoseJudge:
    """Three pose estimators following one clip: of the fitted landmarks, of the visible
    ones, of the annotated ones."""

    def __init__(self) -> None:
        self.estimators = {w: HeadPoseEstimator() for w in (*WAYS, "truth")}

    def reset(self) -> None:
        for estimator in self.estimators.values():
            estimator.reset()

    def judge(self, points: np.ndarray, occluded: np.ndarray, truth: np.ndarray,
              size: tuple[int, int], occluder: bool, tally: PoseErrors) -> None:
        visible = np.where(occluded[:, None], np.nan, points)
        poses = {}
        for way, landmarks in zip((*WAYS, "truth"), (points, visible, truth), strict=True):
            try:
                poses[way] = self.estimators[way].estimate(landmarks, *size).estimate.R
            except (PoseError, IntrinsicsError, ValueError):
                poses[way] = None
        if poses["truth"] is None:
            return
        frames = "occluded" if occluder else "clean"
        for way in WAYS:
            if poses[way] is None:
                tally.missing[(frames, way)] = tally.missing.get((frames, way), 0) + 1
            else:
                tally.errors.setdefault((frames, way), []).append(
                    angle_deg(poses[way], poses["truth"]))
