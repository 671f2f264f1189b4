"""services.stack.drain: when a run's results are all in (the launcher's and record's rule)."""

from __future__ import annotations

from proto.golden import golden_messages
from services.stack.drain import DRAIN_QUIET, EndOfRun


def test_a_run_is_over_once_the_last_frames_fit_came_and_results_stopped() -> None:
    golden = golden_messages()  # a fit of frame 42, an end of stream of 43 frames
    end = EndOfRun(drain_max=20.0)
    end.saw(golden["eos"])
    assert not end.over()  # frame 42's fit has not come (fits come after the end of stream)
    end.eos_at -= 19.0
    assert not end.over()
    end.saw(golden["fit"])
    assert not end.over()  # it came just now: other results may follow
    end.last -= DRAIN_QUIET
    assert end.over()
    late = EndOfRun(drain_max=20.0)
    late.saw(golden["eos"])
    late.eos_at -= 20.0
    assert late.over()  # no fit within --drain-max: over all the same
