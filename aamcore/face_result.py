"""What the tracker found of one face in one frame (:class:`FaceResult`), and the one join
of a frame's fit, pose and expression into it, for the library and for a recording's
messages (``aamtrack export``)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aamcore.expression.recogniser import Recognition
from aamcore.model.similarity import Similarity
from aamcore.operators.faces import FaceFit, FacePose, FrameRef

NO_FACE = "no face"
"""The reason of a result without a face (:data:`aamcore.operators.faces.NO_FACE`)."""


@dataclass(frozen=True, eq=False)
class FaceResult:
    """What the tracker found of one face in one frame.

    Attributes
    ----------
    frame_index : int
    timestamp : float
        Seconds (the frame's, or ``frame_index / 30``).
    success : bool
        A face was found and its fit passed the failure test.
    confidence : float
        How good the fit is, 0 to 1 (0 without a face or for a failed fit): from
        the learned quality score with the default method
        (:meth:`~aamcore.fitting.failure.QualityTest.confidence`), from the
        appearance's chi-square with the AAM methods.
    landmarks : (N, 2) float64 array
        Landmarks in pixels; ``(0, 2)`` without a face.
    similarity : Similarity or None
        The 2D placement of the model frame in the image.
    rotation : (3, 3) array or None
        Head rotation, model to camera (``X_cam = R X_model + T``).
    translation_mm : (3,) array or None
        Head model origin in camera coordinates, millimetres.
    roll_deg, pitch_deg, yaw_deg : float
        The rotation as angles (NaN without a pose).
    pose_reliable : bool
    expression : str or None
        None when no classifier was given, or the face was not classified
        (``expression_reason`` says why).
    expression_scores : dict of str to float
    reason : str
        Why there is no face, the fit failed, there is no pose or the pose is
        unreliable; empty otherwise.
    expression_reason : str
        Why there is no expression (``"<key>: <details>"``: no face, face in
        profile, learning the face's reference, ...); empty with one or
        without a classifier.
    occluded : (N,) bool array or None
        Per landmark, whether its part of the face is covered (from the AAM's
        texture residual); None where it was not judged (no face, a failed fit,
        a model without an occlusion part).
    face_id : int
        Which face (:class:`~aamcore.fitting.multi.TrackedFace`): the same while it is
        tracked (always 0 with one face at a time); -1 for a frame without a tracked face
        (no face, or a failed fit).
    """

    frame_index: int
    timestamp: float
    success: bool
    confidence: float
    landmarks: np.ndarray
    similarity: Similarity | None = None
    rotation: np.ndarray | None = None
    translation_mm: np.ndarray | None = None
    roll_deg: float = math.nan
    pitch_deg: float = math.nan
    yaw_deg: float = math.nan
    pose_reliable: bool = False
    expression: str | None = None
    expression_scores: dict[str, float] = field(default_factory=dict)
    reason: str = ""
    expression_reason: str = ""
    occluded: np.ndarray | None = None
    face_id: int = -1

    def to_dict(self) -> dict[str, Any]:
        """The result as plain JSON-ready data (lists, floats, None for what is missing)."""

        def num(x: float) -> float | None:
            return None if math.isnan(x) else float(x)

        sim = self.similarity
        return {
            "frame": self.frame_index, "face_id": self.face_id, "timestamp": self.timestamp,
            "success": self.success,
            "confidence": float(self.confidence), "landmarks": self.landmarks.tolist(),
            "similarity": None if sim is None else [sim.a, sim.b, sim.tx, sim.ty],
            "rotation": None if self.rotation is None else self.rotation.tolist(),
            "translation_mm": (None if self.translation_mm is None
                               else self.translation_mm.tolist()),
            "roll_deg": num(self.roll_deg), "pitch_deg": num(self.pitch_deg),
            "yaw_deg": num(self.yaw_deg), "pose_reliable": self.pose_reliable,
            "expression": self.expression, "expression_scores": dict(self.expression_scores),
            "reason": self.reason, "expression_reason": self.expression_reason,
            "occluded": None if self.occluded is None else [bool(v) for v in self.occluded],
        }


@dataclass(frozen=True)
class PoseParts:
    """The head pose of one frame as a result carries it (from the library's estimate or a
    ``pose`` message)."""

    rotation: np.ndarray
    translation_mm: np.ndarray
    roll_deg: float
    pitch_deg: float
    yaw_deg: float
    reliable: bool
    reason: str = ""


def joined_result(index: int, t: float, points: np.ndarray, success: bool, confidence: float,
                  similarity: Similarity | None, reason: str, occluded: np.ndarray | None,
                  pose: PoseParts | None, label: str | None, class_names: tuple[str, ...],
                  scores: np.ndarray | None, expression_reason: str, face_id: int = -1
                  ) -> FaceResult:
    """The one join of a frame's fit, pose and expression into a :class:`FaceResult`, for the
    library (:func:`result_of`) and for a recording's messages (``aamtrack export``).

    Without landmarks the frame has no face (``reason`` or "no face"); a pose is reliable
    only on a good fit; the fit's reason comes before the pose's; scores come with a label.
    """
    if len(points) == 0:
        return FaceResult(index, t, False, 0.0, np.zeros((0, 2)), reason=reason or NO_FACE,
                          expression_reason=expression_reason, face_id=face_id)
    named = ({} if label is None or scores is None
             else dict(zip(class_names, map(float, scores), strict=True)))
    common: dict[str, Any] = dict(similarity=similarity, expression=label,
                                  expression_scores=named, expression_reason=expression_reason,
                                  occluded=occluded, face_id=face_id)
    if pose is None:
        return FaceResult(index, t, success, confidence, points, reason=reason, **common)
    return FaceResult(index, t, success, confidence, points, rotation=pose.rotation,
                      translation_mm=pose.translation_mm, roll_deg=float(pose.roll_deg),
                      pitch_deg=float(pose.pitch_deg), yaw_deg=float(pose.yaw_deg),
                      pose_reliable=bool(pose.reliable and success),
                      reason=reason or pose.reason, **common)


def result_of(frame: FrameRef, face: FaceFit, pose: FacePose | None,
              expression: Recognition | None) -> FaceResult:
    """The library's :class:`FaceResult` of one face's entries from the stages'
    operators (:func:`joined_result`)."""
    fit = face.fit
    occluded = face.occluded if not face.failed else None
    parts = None
    if pose is not None and pose.found:
        roll, pitch, yaw = pose.angles_deg
        parts = PoseParts(pose.rotation, pose.translation_mm, roll, pitch, yaw,  # type: ignore
                          pose.reliable, pose.reason)
    why = f"no pose: {pose.reason}" if pose is not None and not pose.found else ""
    label, names, scores, expression_reason = None, (), None, ""
    if expression is not None:
        label, names, scores = expression.label, expression.class_names, expression.scores
        expression_reason = expression.reason
    confidence = 0.0 if fit is None else fit.confidence
    similarity = None if fit is None else fit.similarity
    return joined_result(frame.index, frame.t, face.points, not face.failed, confidence,
                         similarity, face.reason or why, occluded, parts, label, names,
                         scores, expression_reason, face.face_id)
