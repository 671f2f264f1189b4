"""services.bus.stats: gaps in a run's frame numbers, for a first process and a restarted one."""

from __future__ import annotations

from proto import Header
from services.bus.stats import FrameNumbering, ServiceStats


def _arrive(numbering: FrameNumbering, *indices: int, run: str = "run-a") -> None:
    for k in indices:
        numbering.arrived(Header.now("cam0", k, "source", run_id=run))


def test_a_first_process_counts_from_frame_0_and_a_restarted_one_from_its_first() -> None:
    first, restarted = ServiceStats(), ServiceStats()
    _arrive(FrameNumbering(first), 80, 81, 83)
    _arrive(FrameNumbering(restarted, from_first=True), 80, 81, 83)
    assert (first.lost, restarted.lost) == (80 + 1, 1)
    again = FrameNumbering(restarted, from_first=True)
    _arrive(again, 500)
    _arrive(again, 3, run="run-b")  # a new run is numbered from 0 whatever came before
    assert restarted.lost == 1 + 3
