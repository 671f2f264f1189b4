"""Names from messages stay single entity path parts."""

from __future__ import annotations

from rerun import TextLog

from services.rerun_logger.entities import EXPRESSION_SERIES, child


def test_child_escapes_names_into_one_part(new_recording, rrd_tools):
    read, _ = rrd_tools
    assert child(EXPRESSION_SERIES, "happy") == "series/expression/happy"
    escaped = child(EXPRESSION_SERIES, "very/happy face")
    assert escaped == r"series/expression/very\/happy\ face"
    rec = new_recording()
    rec.stream.log(escaped, TextLog("x"), static=True)
    rec.close()
    assert r"/series/expression/very\/happy\ face" in read(rec.rrd_path).entities
