"""The viewer layout: video with landmarks and boxes, overlay, 3D head pose, time series."""

from __future__ import annotations

import rerun.blueprint as rrb

from services.rerun_logger import entities as ent


def build_blueprint() -> rrb.Blueprint:
    """The default layout of an aamtrack recording.

    Top row: the video with its landmarks and face boxes, the AR overlay, and
    the 3D view of the camera and the posed head model. Bottom row: expression
    scores and per-stage latency side by side, then tabs with fit quality,
    pose angles, service status and the event log.
    """
    top = rrb.Horizontal(
        rrb.Spatial2DView(origin=ent.CAMERA, name="Video, landmarks, boxes"),
        rrb.Spatial2DView(origin=ent.OVERLAY, name="AR overlay"),
        rrb.Spatial2DView(origin=ent.RESIDUAL, name="AAM texture residual"),
        rrb.Spatial3DView(origin=ent.WORLD, name="Head pose"),
    )
    bottom = rrb.Horizontal(
        rrb.TimeSeriesView(origin=ent.EXPRESSION_SERIES, name="Expression scores"),
        rrb.TimeSeriesView(origin=ent.LATENCY_SERIES, name="Latency from capture (ms)"),
        rrb.Tabs(
            rrb.TimeSeriesView(origin=ent.FIT_SERIES, name="Fit quality"),
            rrb.TimeSeriesView(origin=ent.POSE_SERIES, name="Pose angles (deg)"),
            rrb.TimeSeriesView(origin=ent.STATUS_SERIES, name="Service status"),
            rrb.TextLogView(origin=ent.EVENTS, name="Events"),
        ),
    )
    return rrb.Blueprint(rrb.Vertical(top, bottom, row_shares=[3, 2]))
