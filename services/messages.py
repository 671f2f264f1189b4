"""The stages' inputs and outputs (:mod:`aamcore.operators.faces`) as messages and back: what
a service adapter turns a received message into before it calls its operator, and the
operator's answers into before it publishes them. One place maps the library's values to
the contract (:mod:`proto`)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from aamcore.fitting.result import AAMFit
from aamcore.operators.faces import FaceFit, FacePose, FrameRef
from proto import Expression, Fit, FitAppearance, Header, HeadPose

if TYPE_CHECKING:  # each service loads only what its own stage needs
    from aamcore.expression.recogniser import Recognition
    from aamcore.warp.reference_frame import ReferenceFrame
    from services.bus.session import Service

EMPTY_POINTS = np.zeros((0, 2), np.float32)
EMPTY = np.zeros(0, np.float32)
MAX_REASON = 512
"""Characters of a reason kept in an expression message (the contract allows 1024 bytes)."""


def frame_of(message: Fit | HeadPose) -> FrameRef:
    """The frame a fit or pose belongs to: its index, media time and size."""
    h = message.header
    return FrameRef(h.frame_index, h.media_time_ns / 1e9, message.image_width,
                    message.image_height)


def face_of(fit: Fit) -> FaceFit:
    """One face's fit as the pose and expression stages take it."""
    occluded = None
    if fit.appearance is not None and len(fit.appearance.occluded):
        occluded = np.asarray(fit.appearance.occluded).astype(bool)
    return FaceFit(fit.face_id, fit.landmarks, fit.failed, fit.failure_reason, fit.c, occluded,
                   fit.scheme)


def pose_of(pose: HeadPose) -> FacePose:
    """One face's pose as the overlay stage takes it."""
    return FacePose(pose.face_id, pose.rotation, pose.translation_mm,
                    (pose.roll_deg, pose.pitch_deg, pose.yaw_deg), pose.intrinsics,
                    pose.reliable, pose.reason, pose.iterations, pose.angle_sd_deg,
                    pose.intrinsics_source, pose.covered)


def fit_message(header: Header, face: FaceFit, warp_path: str, size: tuple[int, int],
                frame: ReferenceFrame | None = None, faces: int = 1) -> Fit:
    """The ``Fit`` message of one face's fit on a frame of ``size``, its warps on
    ``warp_path``; ``frame`` lays an appearance's residual out as an image, ``faces`` is how
    many fits the frame has."""
    result = face.fit
    if result is None:
        return Fit(header, face.scheme, EMPTY_POINTS, EMPTY, *size, True, face.reason, 0.0,
                   warp_path, None, face.face_id, faces)
    sim = result.similarity
    similarity = np.array([sim.a, sim.b, sim.tx, sim.ty])
    finite = bool(np.all(np.isfinite(face.points)) and np.all(np.isfinite(similarity)))
    appearance = appearance_of(result, frame) if finite else None
    failed = bool(result.failed or not finite)
    reason = result.reason or ("non-finite result" if not finite else "")
    confidence = 0.0 if failed or not math.isfinite(result.confidence) else result.confidence
    return Fit(header, face.scheme,
               face.points.astype(np.float32) if finite else EMPTY_POINTS,
               similarity.astype(np.float32) if finite else EMPTY,
               *size, failed, reason if failed else "", float(confidence),
               warp_path if appearance is not None or warp_path != "none" else "none",
               appearance, -1 if failed else face.face_id, faces)


def appearance_of(result: object, frame: ReferenceFrame | None) -> FitAppearance | None:
    """The ``appearance`` of a fit's message: None for a fit without one (or with a
    non-finite one)."""
    if not isinstance(result, AAMFit) or frame is None:
        return None
    if not (np.all(np.isfinite(result.c)) and np.all(np.isfinite(result.residual))
            and math.isfinite(result.error)):
        return None
    occluded = (np.zeros(0, np.uint8) if result.occluded is None
                else result.occluded.astype(np.uint8))
    return FitAppearance(result.c.astype(np.float32),
                         frame.to_image(result.residual.astype(np.float32)),
                         max(float(result.error), 0.0), int(result.iterations),
                         bool(result.converged), occluded)


def pose_message(svc: Service, fit: Fit, pose: FacePose) -> HeadPose:
    """The message of the pose of one fit."""
    roll, pitch, yaw = pose.angles_deg
    return HeadPose(svc.header_for(fit), pose.rotation, pose.translation_mm, roll, pitch, yaw,
                    pose.K, fit.image_width, fit.image_height, pose.camera, pose.iterations,
                    pose.reliable, pose.reason, pose.angle_sd_deg, fit.face_id,
                    EMPTY_POINTS if pose.covered is None else pose.covered.astype(np.float32))


def expression_message(svc: Service, fit: Fit, found: Recognition) -> Expression:
    """The message of a fit: its label and probabilities, or no label and the reason."""
    if found.label is None or found.scores is None:
        return unlabelled(svc, fit, found.reason or "not classified", found.class_names)
    return Expression(svc.header_for(fit), found.label, found.class_names,
                      found.scores.astype(np.float32), found.smoothed, "", fit.face_id)


def unlabelled(svc: Service, fit: Fit, reason: str, class_names: tuple[str, ...] = ()
               ) -> Expression:
    """The answer to a fit without expression: no label, the reason."""
    return Expression(svc.header_for(fit), "", class_names, np.zeros(0, np.float32), False,
                      reason[:MAX_REASON], fit.face_id)
