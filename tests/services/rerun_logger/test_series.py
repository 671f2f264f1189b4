"""Series entities get their legend name once and skip NaN values."""

from __future__ import annotations

import math

from services.rerun_logger.series import SeriesWriter


def test_series_writer_names_once_and_skips_nan(new_recording, rrd_tools):
    read, verify = rrd_tools
    rec = new_recording()
    series = SeriesWriter(rec.stream)
    logged = []
    for i, value in enumerate([1.5, math.nan, -2.0, 7]):
        rec.stream.set_time("frame", sequence=i)
        logged.append(series.scalar("series/a", value, "first series"))
        series.scalar("series/b/c", i)
    rec.close()
    verify(rec.rrd_path)
    content = read(rec.rrd_path)
    assert logged == [True, False, True, True]
    assert content.mono("/series/a", "Scalars:scalars") == [1.5, -2.0, 7.0]
    assert content.frames("/series/a", "Scalars:scalars") == [0, 2, 3]
    static_rows = [r for r in content.rows["/series/a"] if r["static"]]
    assert [r["SeriesLines:names"] for r in static_rows] == [["first series"]]
    assert content.static("/series/b/c", "SeriesLines:names") == ["c"]
