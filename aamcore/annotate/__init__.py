"""An annotated video: each frame with what was found in it drawn on it.

:class:`Annotator` draws a frame's :class:`~aamcore.face_result.FaceResult` list on the
frame: the glasses at each reliable pose by the AR renderer
(:class:`aamcore.ar.renderer.GlassesRenderer`, hidden by the head), the landmarks coloured
by facial part with occluded ones ringed, the head's axes, and a label per face with its id
and expression (with its probability) or the reason it has none; a frame without a face
says why. :class:`VideoWriter` writes the frames; :class:`AnnotatedVideo` does both in a
thread of its own, beside the tracking. ``aamtrack track VIDEO --annotate OUT.mp4``
and ``aamtrack export RUN.rec --video VIDEO --annotate OUT.mp4`` use them.
"""

from __future__ import annotations

from aamcore.annotate.annotator import Annotator
from aamcore.annotate.video import AnnotatedVideo, VideoWriter, video_output_problem

__all__ = ["AnnotatedVideo", "Annotator", "VideoWriter", "video_output_problem"]
