"""aamcore.fitting.search: which frames without a face are searched, and how."""

from __future__ import annotations

import pytest

from aamcore.fitting.search import SearchSchedule


def test_the_frames_after_a_loss_are_searched_both_ways_then_spread() -> None:
    schedule = SearchSchedule()
    assert all(schedule.passes(k) == (True, True) for k in range(schedule.eager))
    later = [schedule.passes(k) for k in range(schedule.eager, schedule.eager + 100)]
    upright = [k for k, (u, _) in enumerate(later) if u]
    turned = [k for k, (_, t) in enumerate(later) if t]
    assert max(b - a for a, b in zip(upright, upright[1:], strict=False)) <= 3
    assert max(b - a for a, b in zip(turned, turned[1:], strict=False)) <= 5
    assert len(upright) + len(turned) == 54  # 8 passes in 15 frames, not 30


def test_every_frame_searches_both_ways_and_bad_schedules_are_refused() -> None:
    assert all(SearchSchedule.every_frame().passes(k) == (True, True) for k in range(50))
    with pytest.raises(ValueError, match="upright_every 0: must be a whole number from 1"):
        SearchSchedule(upright_every=0)
