"""Entity paths and timelines of the aamtrack Rerun recording.

The loggers write to these paths and the blueprint lays views out over them,
so both read them from here. The world is the camera frame of OpenCV (x right,
y down, z forward, millimetres): the camera sits at the origin, the head moves
in front of it, and the video with its 2D annotations hangs under the camera's
pinhole so that the 3D view shows it in the camera frustum.
"""

from __future__ import annotations

import rerun as rr

FRAME_TIMELINE = "frame"
"""Sequence timeline: the frame index of each message's header."""
CAPTURE_TIMELINE = "capture_time"
"""Timestamp timeline: the capture time of each message's frame."""

WORLD = "world"
CAMERA = "world/camera"
VIDEO = "world/camera/video"
BOXES = "world/camera/boxes"
LANDMARKS = "world/camera/landmarks"
FACE = "world/camera/face"
"""The box around a face's landmarks, in the face's colour and labelled with its id."""
OCCLUDED = "world/camera/occluded"
"""The landmarks the fit's appearance says are covered, drawn over the others."""
HEAD = "world/head"
HEAD_MODEL = "world/head/model"
GLASSES = "world/head/glasses"
GLASSES_FRAME = "world/head/glasses/frame"
GLASSES_LENSES = "world/head/glasses/lenses"
OVERLAY = "overlay"
RESIDUAL = "residual"
"""The AAM's texture residual of the fit in its reference frame, |r| as grey."""

SERIES = "series"
EXPRESSION_SERIES = "series/expression"
LATENCY_SERIES = "series/latency"
FIT_SERIES = "series/fit"
POSE_SERIES = "series/pose"
STATUS_SERIES = "series/status"
EVENTS = "events"


def child(parent: str, name: str) -> str:
    """``parent/name`` with ``name`` escaped into a single entity path part.

    Names that come from messages (class names, service names) may hold
    characters that mean something in an entity path, such as ``/`` or a space.
    """
    return f"{parent}/{rr.escape_entity_path_part(name)}"


def of_face(path: str, face_id: int) -> str:
    """The entity of ``path`` for face ``face_id``: ``path`` itself for the first face (0,
    or -1 for a frame without one), ``path_<id>`` beside it for another (a head's whole
    subtree: ``world/head_<id>/...``)."""
    if face_id <= 0:
        return path
    if path == HEAD or path.startswith(HEAD + "/"):
        return f"{HEAD}_{face_id}{path[len(HEAD):]}"
    return f"{path}_{face_id}"
