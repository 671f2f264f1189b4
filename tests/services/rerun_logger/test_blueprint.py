"""The blueprint lays out the views over the entities the loggers write."""

from __future__ import annotations

import rerun.blueprint as rrb

from services.rerun_logger import entities as ent
from services.rerun_logger.blueprint import build_blueprint
from services.rerun_logger.recording import open_recording


def test_blueprint_is_written_with_a_view_per_output(tmp_path, rrd_tools):
    read, verify = rrd_tools
    blueprint = build_blueprint()
    assert isinstance(blueprint, rrb.Blueprint)
    rec = open_recording(tmp_path / "bp.rrd", blueprint=blueprint)
    rec.close()
    verify(rec.rrd_path)
    rows = read(rec.rrd_path).blueprint_rows
    views = {}
    for row in rows:
        if "ViewBlueprint:space_origin" in row:
            views[row["ViewBlueprint:space_origin"][0]] = row["ViewBlueprint:class_identifier"][0]
    assert views == {
        ent.CAMERA: "2D",
        ent.OVERLAY: "2D",
        ent.RESIDUAL: "2D",
        ent.WORLD: "3D",
        ent.EXPRESSION_SERIES: "TimeSeries",
        ent.LATENCY_SERIES: "TimeSeries",
        ent.FIT_SERIES: "TimeSeries",
        ent.POSE_SERIES: "TimeSeries",
        ent.STATUS_SERIES: "TimeSeries",
        ent.EVENTS: "TextLog",
    }
