"""Route decoded messages to their logger at the time of their frame."""

from __future__ import annotations

import numpy as np
import rerun as rr

from aamcore.ar.glasses_mesh import GlassesMesh
from aamcore.pose.head_model import HeadModel
from proto.messages import MESSAGE_TYPES, EndOfStream, Message
from services.rerun_logger import entities as ent
from services.rerun_logger import loggers
from services.rerun_logger.annotations import LandmarkClasses
from services.rerun_logger.options import DEFAULT_QUALITY
from services.rerun_logger.series import SeriesWriter


class StreamLogger:
    """Logs every kind of message of a stream into one recording.

    Each message is logged on the ``frame`` sequence timeline at its header's
    frame index and on the ``capture_time`` timeline at its capture time. Call
    :meth:`log` from one thread only: Rerun keeps the current time per thread.

    Parameters
    ----------
    rec : rerun.RecordingStream
        Where to log (with its sinks already set).
    head_model : HeadModel, optional
        3D head model drawn with the pose (see :class:`PoseLogger`).
    jpeg_quality : int
        JPEG quality for raw frames and overlays.
    glasses : GlassesMesh, optional
        AR glasses drawn on the 3D head (see :class:`PoseLogger`).
    """

    def __init__(
        self,
        rec: rr.RecordingStream,
        head_model: HeadModel | None = None,
        jpeg_quality: int = DEFAULT_QUALITY,
        glasses: GlassesMesh | None = None,
    ) -> None:
        self._rec = rec
        classes = LandmarkClasses()
        series = SeriesWriter(rec)
        self.frames = loggers.ImageLogger(rec, ent.VIDEO, jpeg_quality)
        self.overlays = loggers.ImageLogger(rec, ent.OVERLAY, jpeg_quality)
        self.boxes = loggers.BoxesLogger(rec)
        self.fits = loggers.FitLogger(rec, classes, series)
        self.poses = loggers.PoseLogger(rec, classes, series, head_model, glasses)
        self.expressions = loggers.ExpressionLogger(rec, series)
        self.latency = loggers.LatencyLogger(series)
        self.statuses = loggers.StatusLogger(rec, series)
        self._by_kind = {
            "frame": self.frames.log, "overlay": self.overlays.log, "boxes": self.boxes.log,
            "fit": self.fits.log, "pose": self.poses.log, "expression": self.expressions.log,
            "status": self.statuses.log, "eos": self._log_end,
        }
        self.counts: dict[str, int] = {}
        """Messages logged, by kind."""

    def set_time(self, msg: Message) -> None:
        """Set the recording's timelines to the frame of ``msg``."""
        self._rec.set_time(ent.FRAME_TIMELINE, sequence=msg.header.frame_index)
        self._rec.set_time(
            ent.CAPTURE_TIMELINE, timestamp=np.datetime64(msg.header.capture_time_ns, "ns")
        )

    def log(self, msg: Message) -> None:
        """Log ``msg`` with the logger of its kind.

        Raises
        ------
        TypeError
            For an object that is not one of the proto message kinds.
        """
        if type(msg) is not MESSAGE_TYPES.get(getattr(msg, "KIND", "")):
            raise TypeError(f"not a proto message: {type(msg).__name__}")
        self.set_time(msg)
        self._by_kind[msg.KIND](msg)
        self.latency.log(msg)
        self.counts[msg.KIND] = self.counts.get(msg.KIND, 0) + 1

    def note(self, text: str) -> None:
        """An event line of the recording's own, for all of it (what its messages were
        checked against)."""
        self._rec.log(ent.EVENTS, rr.TextLog(text), static=True)

    def _log_end(self, msg: EndOfStream) -> None:
        self._rec.log(ent.EVENTS,
                      rr.TextLog(f"end of stream after {msg.total_frames} frames: {msg.reason}"))
