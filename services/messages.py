"""Messages read as the stages' operators take them (:mod:`aamcore.operators.faces`): what
an adapter turns a received ``Fit`` or ``HeadPose`` into before it calls its operator."""

from __future__ import annotations

import numpy as np

from aamcore.operators.faces import FaceFit, FacePose, FrameRef
from proto import Fit, HeadPose


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
                    pose.intrinsics_source)
