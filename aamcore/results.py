"""Per-frame results as CSV or JSON Lines, one row per face per frame, as OpenFace users
load them (its multi-face CSV has the same shape).

Columns of the CSV (one row per face per frame, one row for a frame without a face,
written and flushed as it comes, so a run cut short keeps every row before the cut)::

    frame, face_id, timestamp, success, confidence,
    pose_Tx, pose_Ty, pose_Tz, pose_roll, pose_pitch, pose_yaw, pose_reliable,
    x_0 ... x_{N-1}, y_0 ... y_{N-1}, occluded_0 ... occluded_{N-1},
    expression, score_<class> ..., expression_reason, reason

A writer given ``extra`` columns (``aamtrack export``: ``run_id``, ``verified``, what each
row's messages were checked against) writes them last, the same in every row.
``face_id`` is the face's id (:attr:`aamcore.tracker.FaceResult.face_id`), empty for a
frame without a tracked face.
``occluded_i`` is 1 where landmark ``i``'s part of the face is covered (from the
AAM's texture residual), 0 where it is not, empty where it was not judged;
``score_<class>`` are probabilities summing to 1; ``expression_reason`` says why a
frame has no expression label, ``reason`` why it has no face, a failed fit or an
unreliable pose.

Translations are millimetres in camera coordinates, angles degrees; a value
that does not exist for a frame (no face, no pose) is left empty. JSON Lines
hold :meth:`aamcore.tracker.FaceResult.to_dict` per line.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

if TYPE_CHECKING:
    from aamcore.tracker import FaceResult

FORMATS = ("csv", "jsonl")


def columns(n_points: int, class_names: Sequence[str]) -> list[str]:
    """The CSV header for ``n_points`` landmarks and these expression classes."""
    return (["frame", "face_id", "timestamp", "success", "confidence", "pose_Tx", "pose_Ty",
             "pose_Tz", "pose_roll", "pose_pitch", "pose_yaw", "pose_reliable"]
            + [f"x_{i}" for i in range(n_points)] + [f"y_{i}" for i in range(n_points)]
            + [f"occluded_{i}" for i in range(n_points)]
            + ["expression"] + [f"score_{name}" for name in class_names]
            + ["expression_reason", "reason"])


def _cell(value: float) -> str:
    return "" if value is None or (isinstance(value, float) and math.isnan(value)) else (
        f"{value:.6g}")


def row(result: FaceResult, n_points: int, class_names: Sequence[str]) -> list[str]:
    """The CSV cells of one result."""
    t = result.translation_mm
    pose = ["", "", ""] if t is None else [_cell(float(v)) for v in t]
    points = result.landmarks
    if len(points) == n_points:
        xs = [f"{v:.3f}" for v in points[:, 0]]
        ys = [f"{v:.3f}" for v in points[:, 1]]
    else:
        xs = ys = [""] * n_points
    flags = result.occluded
    occluded = ([str(int(v)) for v in flags] if flags is not None and len(flags) == n_points
                else [""] * n_points)
    scores = [_cell(result.expression_scores.get(name, math.nan)) for name in class_names]
    face = str(result.face_id) if result.face_id >= 0 else ""
    return ([str(result.frame_index), face, f"{result.timestamp:.6f}", str(int(result.success)),
             f"{result.confidence:.4f}", *pose, _cell(result.roll_deg),
             _cell(result.pitch_deg), _cell(result.yaw_deg),
             str(int(result.pose_reliable)) if t is not None else "", *xs, *ys, *occluded,
             result.expression or "", *scores, result.expression_reason, result.reason])


class ResultWriter:
    """Write results to a CSV or JSON Lines file, flushing every row.

    Parameters
    ----------
    path : path
    kind : {"csv", "jsonl"}
    n_points : int
        Landmarks per face (the columns ``x_i``, ``y_i``).
    class_names : sequence of str
        Expression classes (the columns ``score_<class>``), possibly none.
    extra : mapping of str to str
        Columns added after the others, one value for every row.
    """

    def __init__(self, path: str | Path, kind: str, n_points: int,
                 class_names: Sequence[str] = (), extra: Mapping[str, str] | None = None
                 ) -> None:
        if kind not in FORMATS:
            raise ValueError(f"unknown result format {kind!r}: choose one of {FORMATS}")
        self.path = Path(path)
        self.kind = kind
        self.n_points = n_points
        self.class_names = tuple(class_names)
        self.extra = dict(extra or {})
        self.count = 0
        self._file: TextIO = open(self.path, "w", newline="")  # noqa: SIM115 (closed in close)
        self._csv: Any = None
        if kind == "csv":
            self._csv = csv.writer(self._file)
            self._csv.writerow(columns(n_points, self.class_names) + list(self.extra))

    def write(self, result: FaceResult) -> None:
        if self._csv is not None:
            self._csv.writerow(row(result, self.n_points, self.class_names)
                               + list(self.extra.values()))
        else:
            self._file.write(json.dumps(result.to_dict() | self.extra) + "\n")
        self._file.flush()
        self.count += 1

    def close(self) -> None:
        self._file.close()

    def __enter__(self) -> ResultWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
