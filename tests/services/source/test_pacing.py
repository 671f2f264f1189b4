"""services.source.pacing: real-time pacing and the bounded in-flight window."""

from __future__ import annotations

import threading
import time

import pytest

from services.source.pacing import CreditWindow, RealTimePacer


def test_real_time_pacer_spaces_frames_by_the_period() -> None:
    pacer = RealTimePacer(50.0, lambda s: time.sleep(s) or False)
    start = time.monotonic()
    for k in range(6):
        assert pacer.wait(k)
    assert time.monotonic() - start == pytest.approx(0.1, abs=0.03)


def test_real_time_pacer_wait_is_abandoned_on_stop() -> None:
    pacer = RealTimePacer(1.0, lambda s: True)  # a sleep that is always interrupted
    assert pacer.wait(0)  # frame 0 is due at once: no sleep to interrupt
    assert not pacer.wait(5)
    with pytest.raises(ValueError):
        RealTimePacer(0.0, lambda s: False)


def test_credit_window_lets_at_most_window_frames_ahead() -> None:
    window = CreditWindow(window=2, timeout=5.0)
    assert window.wait(0) and window.wait(1)  # frames 0 and 1 in flight
    released = threading.Event()

    def third() -> None:
        window.wait(2)
        released.set()

    threading.Thread(target=third).start()
    assert not released.wait(0.2), "frame 2 went out with two frames unanswered"
    window.answer(0)
    assert released.wait(2.0)
    assert window.timeouts == 0


def test_credit_window_gives_up_on_a_lost_answer_after_the_timeout() -> None:
    window = CreditWindow(window=1, timeout=0.1)
    window.wait(0)
    start = time.monotonic()
    assert window.wait(1) and window.wait(2)
    assert window.timeouts == 2 and time.monotonic() - start < 1.0


def test_credit_window_stop_releases_a_waiter() -> None:
    window = CreditWindow(window=1, timeout=10.0)
    result = []
    t = threading.Thread(target=lambda: result.append(window.wait(5)))
    t.start()
    time.sleep(0.05)
    window.stop()
    t.join(2.0)
    assert result == [False]
