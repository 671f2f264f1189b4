"""services.rerun_logger.files: the parts of a logger, and the part a dead logger left."""

from __future__ import annotations

from pathlib import Path

import rerun as rr

from services.rerun_logger.files import finish, part_path, unfinished_parts
from services.rerun_logger.recording import open_recording


def test_parts_are_named_after_the_first_and_only_unclosed_ones_are_finished(
    tmp_path: Path,
) -> None:
    rrd = tmp_path / "run.rrd"
    assert part_path(rrd, 0) == rrd and part_path(rrd, 2) == tmp_path / "run.part2.rrd"
    for k in (0, 2):  # the process of restart 1 died before it made its file
        part_path(rrd, k).write_bytes(b"")
    assert unfinished_parts(rrd, 2, closed={2}) == [rrd]
    assert unfinished_parts(rrd, 2, closed=set()) == [rrd, tmp_path / "run.part2.rrd"]


def test_a_part_cut_anywhere_is_finished_with_its_footer_and_keeps_what_it_held(
    tmp_path: Path, rrd_tools,
) -> None:
    read, verify = rrd_tools
    whole = tmp_path / "whole.rrd"
    rec = open_recording(whole, recording_id="rec-cut")
    for i in range(400):
        rec.stream.set_time("frame", sequence=i)
        rec.stream.log("x", rr.Scalars(float(i)))
        if i % 100 == 99:
            rec.flush()  # four chunks on the file, as a long run has many
    assert rec.close() == ""
    cut = tmp_path / "cut.rrd"
    cut.write_bytes(whole.read_bytes()[: whole.stat().st_size * 2 // 3])  # a killed writer's
    assert finish(cut) == ""
    verify(cut)  # footer included
    kept = read(cut).mono("/x", "Scalars:scalars")
    assert kept == [float(i) for i in range(len(kept))] and len(kept) >= 100
    assert not list(tmp_path.glob("*.backup.rrd"))


def test_a_file_that_is_no_recording_is_left_as_it_was(tmp_path: Path) -> None:
    junk = tmp_path / "junk.rrd"
    junk.write_bytes(b"not a recording\n" * 100)
    assert finish(junk) != ""
    assert junk.read_bytes() == b"not a recording\n" * 100
    assert not list(tmp_path.glob("*.backup.rrd"))
