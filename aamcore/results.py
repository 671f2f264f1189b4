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
``expression`` is the class's code (:data:`EXPRESSIONS`: AN anger, DI disgust, FE fear,
HA happiness, NE neutral, SA sadness, SU surprise) and ``score_<code>`` the probability of
each class, summing to 1; ``expression_reason`` says why a face has no expression label
(:data:`EXPRESSION_REASONS`: no face, face too small, face outside the frame, head rolled,
face covered, face blurred, face in profile, implausible landmarks, learning the face's
reference, ...), ``reason`` why a frame has no face, a failed fit or an unreliable pose
(:data:`REASONS`).
Each reason starts with one of those phrases and goes on with the figures that decided it
(``"face in profile: turned about 52 degrees (at most 40)"``).

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

EXPRESSIONS: dict[str, str] = {
    "AN": "anger", "DI": "disgust", "FE": "fear", "HA": "happiness",
    "NE": "neutral (no expression)", "SA": "sadness", "SU": "surprise"}
"""The expression classes by their code (JAFFE's): the ``expression`` column holds one, and
each has its ``score_<code>`` column."""

EXPRESSION_REASONS: dict[str, str] = {
    "no face": "no face in the frame, or its fit failed (the fit's reason follows)",
    "unusable landmarks": "the fit's landmarks are not the finite 68 the classifier reads",
    "no features": "the features could not be taken from the face (the image's edge)",
    "face too small": "the eyes are closer than the classifier can read",
    "face outside the frame": "too many landmarks beyond the frame",
    "head rolled": "the eye line tilted further than the classifier learned",
    "face covered": "too many inner landmarks flagged occluded, or some flagged and the "
                    "face's texture unlike its mirror image (a hand on one side)",
    "face blurred": "too little sharp texture around the eyes, nose and mouth (out of focus, "
                    "moving, or too few pixels)",
    "face in profile or badly fitted": "the face's texture unlike its mirror image, no inner "
                                       "landmark flagged occluded",
    "face in profile": "the head turned further than the classifier learned",
    "implausible landmarks": "a face shape unlike every face the classifier learned from "
                             "(a fit gone wrong)",
    "learning the face's reference": "the first frames of a face, when the classifier reads "
                                     "faces only against their own neutral reference",
    "no classifier": "the stack's expression service runs without one (why follows)",
    "wrong feature length": "a classifier made for another model",
}
"""Why a face has no expression label: what an ``expression_reason`` starts with."""

REASONS: dict[str, str] = {
    "no face": "no face found in the frame (\"the frame is dark\" when too dark to find one)",
    "face too small": "under 8 px between the outer eye corners",
    "no contrast around the landmarks": "a blank or flat image where the face should be",
    "fit-quality score": "the landmarks' learned quality score says the fit failed",
    "appearance": "an AAM method's failure test (chi-square or eq. 7.2 of the thesis)",
    "non-finite": "the fit diverged",
    "degenerate shape": "the fit collapsed to a line or a point",
    "profile": "the head turned past 75 degrees: half the landmarks are guesses",
    "points outside the frame or missing": "too many landmarks beyond the frame",
    "landmarks do not fit the head": "the head model cannot be placed on these landmarks",
    "too many outlying landmarks": "too few landmarks agree with the head model",
    "poorly determined": "the angles are too uncertain",
    "did not converge": "the pose estimate did not settle",
    "no valid pose": "the head would be behind the camera",
    "the model faces away": "the landmarks are mirrored (left and right swapped?)",
}
"""Why a frame has no face, a failed fit or an unreliable pose: what a ``reason`` starts
with (the fit's reason before the pose's)."""


def explained(reason: str, table: dict[str, str]) -> str:
    """The phrase of ``table`` that ``reason`` starts with, or ``""`` (an empty reason, or
    one no table explains)."""
    return next((key for key in table if reason.startswith(key)), "")


def columns_notes() -> str:
    """The expression codes and the reasons, as the commands' help gives them."""
    codes = ", ".join(f"{code} {word}" for code, word in EXPRESSIONS.items())
    why = "; ".join(EXPRESSION_REASONS)
    bad = "; ".join(REASONS)
    return (f"Expressions, by their code: {codes}. Why a face has no expression label "
            f"(expression_reason): {why}. Why a frame has no face, a failed fit or an "
            f"unreliable pose (reason): {bad}. Each reason goes on with the figures that "
            "decided it; the README explains each.")


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
