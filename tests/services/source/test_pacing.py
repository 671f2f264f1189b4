"""services.source.pacing: real-time pacing and the bounded in-flight window, on clocks the
tests move themselves (no wall-clock bound: the machine's load cannot fail them)."""

from __future__ import annotations

import threading
import time

import pytest

from services.source.pacing import CreditWindow, RealTimePacer


class StepClock:
    """A clock that moves only when asked to: ``step`` seconds at each reading, and as far
    as a sleep asks."""

    def __init__(self, step: float = 0.0) -> None:
        self.now = 1000.0
        self.step = step
        self.slept: list[float] = []

    def __call__(self) -> float:
        self.now += self.step
        return self.now

    def sleep(self, seconds: float) -> bool:
        self.slept.append(seconds)
        self.now += seconds
        return False


class WaitingClock:
    """The real clock, telling when a :class:`CreditWindow` has read it a second time: it is
    then inside its wait, holding the window's lock until it sleeps."""

    def __init__(self) -> None:
        self.readings = 0
        self.waiting = threading.Event()

    def __call__(self) -> float:
        self.readings += 1
        if self.readings == 2:
            self.waiting.set()
        return time.monotonic()


def test_real_time_pacer_puts_frame_k_at_k_periods_and_sends_a_late_frame_at_once() -> None:
    clock = StepClock()
    pacer = RealTimePacer(50.0, clock.sleep, clock)
    start = clock.now
    due = []
    for k in range(6):
        assert pacer.wait(k)
        due.append(clock.now - start)
    assert due == pytest.approx([0.02 * k for k in range(6)], abs=1e-9)
    clock.now += 0.5  # work on frame 5 took 25 periods: frame 6 is late
    slept = len(clock.slept)
    assert pacer.wait(6) and len(clock.slept) == slept  # sent at once, not skipped
    assert pacer.wait(40) and clock.slept[-1] == pytest.approx(0.8 - 0.6, abs=1e-9)
    assert clock.now - start == pytest.approx(0.8, abs=1e-9)  # the schedule, not the delay


def test_real_time_pacer_wait_is_abandoned_on_stop() -> None:
    pacer = RealTimePacer(1.0, lambda s: True)  # a sleep that is always interrupted
    assert pacer.wait(0)  # frame 0 is due at once: no sleep to interrupt
    assert not pacer.wait(5)
    with pytest.raises(ValueError):
        RealTimePacer(0.0, lambda s: False)


def test_credit_window_holds_a_frame_beyond_the_window_until_its_answer() -> None:
    held = CreditWindow(window=2, timeout=5.0, clock=StepClock(step=10.0))
    assert held.wait(0) and held.wait(1) and held.timeouts == 0  # frames 0 and 1 in flight
    assert held.wait(2) and held.timeouts == 1  # held back, given up once the clock passed
    answered = CreditWindow(window=2, timeout=5.0, clock=StepClock(step=10.0))
    assert answered.wait(0) and answered.wait(1)
    answered.answer(0)
    assert answered.wait(2) and answered.timeouts == 0  # the control: its answer came first


def test_credit_window_an_answer_releases_a_waiting_frame() -> None:
    clock = WaitingClock()
    window = CreditWindow(window=2, timeout=600.0, clock=clock)
    assert window.wait(0) and window.wait(1)
    clock.readings = 0  # frames 0 and 1 read it once each
    clock.waiting.clear()
    released = threading.Event()
    threading.Thread(target=lambda: (window.wait(2), released.set()), daemon=True).start()
    assert clock.waiting.wait(60), "frame 2 never waited"
    assert not released.is_set()
    window.answer(0)
    assert released.wait(60)
    assert window.timeouts == 0


def test_credit_window_gives_up_on_a_lost_answer_after_the_timeout() -> None:
    window = CreditWindow(window=1, timeout=0.1, clock=StepClock(step=1.0))
    assert window.wait(0)
    assert window.wait(1) and window.wait(2)
    assert window.timeouts == 2 and window.answered == 1


def test_credit_window_stop_releases_a_waiter() -> None:
    clock = WaitingClock()
    window = CreditWindow(window=1, timeout=600.0, clock=clock)
    result = []
    t = threading.Thread(target=lambda: result.append(window.wait(5)), daemon=True)
    t.start()
    assert clock.waiting.wait(60), "frame 5 never waited"
    window.stop()
    t.join(60)
    assert result == [False]
