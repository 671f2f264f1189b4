"""services.stack.drain: when a run's results are all in (the launcher's and record's rule)."""

from __future__ import annotations

from dataclasses import replace

from proto.golden import golden_messages
from services.stack.drain import DRAIN_QUIET, DRAIN_UNPOSED, EndOfRun


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


def test_a_fit_with_a_face_waiting_for_its_pose_keeps_the_run_open_a_while() -> None:
    golden = golden_messages()  # frame 42's fit has landmarks; its pose is of frame 42 too
    end = EndOfRun(drain_max=20.0)
    end.saw(golden["pose"])  # a pose of another face first: the run has a pose service
    end.saw(golden["eos"])
    end.saw(replace(golden["fit"], face_id=golden["pose"].face_id + 1))
    end.last -= DRAIN_QUIET
    assert not end.over()  # a late pose (a loaded machine, a router) still counts
    end.last -= (DRAIN_UNPOSED - 1) * DRAIN_QUIET
    assert end.over()  # a pose dropped by design does not hold the run to --drain-max
    answered = EndOfRun(drain_max=20.0)
    answered.saw(golden["eos"])
    answered.saw(golden["fit"])
    answered.saw(golden["pose"])
    answered.last -= DRAIN_QUIET
    assert answered.over()
