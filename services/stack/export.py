"""A recording's messages as per-frame results: CSV, JSON Lines or a Rerun recording.

:func:`results_of` joins each frame's fit, pose and expression (by run and
frame index) into an :class:`aamcore.tracker.FaceResult`, the same record the
Python API gives, so that ``aamtrack export RUN.rec --csv`` and ``aamtrack
track VIDEO --csv`` write the same columns.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from aamcore.model.similarity import Similarity
from aamcore.tracker import NO_FACE, FaceResult
from proto import Expression, Fit, HeadPose, Message


@dataclass(frozen=True)
class Exported:
    """The results of a recording and what their columns need."""

    results: list[FaceResult]
    n_points: int
    class_names: tuple[str, ...]


def face_result(fit: Fit, pose: HeadPose | None, expression: Expression | None) -> FaceResult:
    """The result of one frame from its messages, timed on the video's clock."""
    h = fit.header
    t = h.media_time_ns / 1e9
    points = np.asarray(fit.landmarks, np.float64)
    labelled = expression is not None and bool(expression.label)
    why = "" if expression is None or labelled else expression.reason
    if len(points) == 0:
        return FaceResult(h.frame_index, t, False, 0.0, np.zeros((0, 2)),
                          reason=fit.failure_reason or NO_FACE, expression_reason=why)
    a, b, tx, ty = (float(v) for v in fit.similarity)
    scores = ({} if expression is None or not labelled
              else dict(zip(expression.class_names, map(float, expression.scores), strict=True)))
    found = fit.appearance
    occluded = (np.asarray(found.occluded, bool) if found is not None
                and len(found.occluded) == len(points) else None)
    common = dict(similarity=Similarity(a, b, tx, ty), reason=fit.failure_reason,
                  expression=expression.label if labelled else None, expression_scores=scores,
                  expression_reason=why, occluded=occluded)
    confidence = float(fit.confidence)
    if pose is None:
        return FaceResult(h.frame_index, t, not fit.failed, confidence, points, **common)
    return FaceResult(h.frame_index, t, not fit.failed, confidence, points,
                      rotation=np.asarray(pose.rotation), translation_mm=np.asarray(
                          pose.translation_mm), roll_deg=pose.roll_deg,
                      pitch_deg=pose.pitch_deg, yaw_deg=pose.yaw_deg,
                      pose_reliable=pose.reliable,
                      **{**common, "reason": fit.failure_reason or pose.reason})


def _by_frame(messages: Iterable[Message], kind: str) -> dict[tuple[str, int], Message]:
    return {(m.header.run_id, m.header.frame_index): m for m in messages if kind == m.KIND}


def results_of(messages: list[Message]) -> Exported:
    """Every frame with a fit, in order, with its pose and expression when there are."""
    fits = [m for m in messages if isinstance(m, Fit)]
    poses = _by_frame(messages, "pose")
    expressions = _by_frame(messages, "expression")
    results = []
    for fit in fits:
        key = (fit.header.run_id, fit.header.frame_index)
        results.append(face_result(fit, poses.get(key), expressions.get(key)))
    n_points = max((len(f.landmarks) for f in fits), default=0)
    names = next((tuple(m.class_names) for m in expressions.values()
                  if isinstance(m, Expression) and m.class_names), ())
    return Exported(results, n_points, names)
