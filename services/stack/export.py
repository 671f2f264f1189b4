"""A recording's messages as per-frame results: CSV, JSON Lines or a Rerun recording.

:func:`results_of` joins each face's fit, pose and expression (by run, frame
index and face id) into an :class:`aamcore.tracker.FaceResult`, the same record the
Python API gives, so that ``aamtrack export RUN.rec --csv`` and ``aamtrack
track VIDEO --csv`` write the same columns.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace

import numpy as np

from aamcore.face_result import FaceResult, PoseParts, joined_result
from aamcore.model.similarity import Similarity
from proto import Expression, Fit, HeadPose, Message


@dataclass(frozen=True)
class Exported:
    """The results of a recording and what their columns need."""

    results: list[FaceResult]
    n_points: int
    class_names: tuple[str, ...]


def face_result(fit: Fit, pose: HeadPose | None, expression: Expression | None) -> FaceResult:
    """The result of one frame from its messages, timed on the video's clock
    (:func:`aamcore.tracker.joined_result`, as the library's)."""
    h = fit.header
    points = np.asarray(fit.landmarks, np.float64)
    found = fit.appearance
    occluded = (np.asarray(found.occluded, bool) if found is not None
                and len(found.occluded) == len(points) else None)
    a, b, tx, ty = (float(v) for v in fit.similarity) if len(points) else (1.0, 0.0, 0.0, 0.0)
    parts = None if pose is None else PoseParts(
        np.asarray(pose.rotation), np.asarray(pose.translation_mm), pose.roll_deg,
        pose.pitch_deg, pose.yaw_deg, pose.reliable, pose.reason)
    label, names, scores, why = None, (), None, ""
    if expression is not None:
        if expression.label:
            label, names = expression.label, tuple(expression.class_names)
            scores = np.asarray(expression.scores, np.float64)
        else:
            why = expression.reason
    result = joined_result(h.frame_index, h.media_time_ns / 1e9, points, not fit.failed,
                           float(fit.confidence), Similarity(a, b, tx, ty), fit.failure_reason,
                           occluded, parts, label, names, scores, why)
    return replace(result, face_id=fit.face_id)


def _by_face(messages: Iterable[Message], kind: str) -> dict[tuple[str, int, int], Message]:
    return {(m.header.run_id, m.header.frame_index, m.face_id): m  # type: ignore[attr-defined]
            for m in messages if kind == m.KIND}


def results_of(messages: list[Message]) -> Exported:
    """Every fit (one per face of a frame), in order, with its pose and expression when there
    are."""
    fits = [m for m in messages if isinstance(m, Fit)]
    poses = _by_face(messages, "pose")
    expressions = _by_face(messages, "expression")
    results = []
    for fit in fits:
        key = (fit.header.run_id, fit.header.frame_index, fit.face_id)
        results.append(face_result(fit, poses.get(key), expressions.get(key)))
    n_points = max((len(f.landmarks) for f in fits), default=0)
    names = next((tuple(m.class_names) for m in expressions.values()
                  if isinstance(m, Expression) and m.class_names), ())
    return Exported(results, n_points, names)
