"""services.bus.inbox: every sample is screened on arrival, so nothing invalid takes a slot.

All on a real loopback Zenoh bus: a probe publishes, a sink's holders receive.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

import numpy as np
import pytest

from proto import EndOfStream, Frame, Header, encode
from services.bus.connection import BusOptions
from services.bus.qos import MUST_ARRIVE
from services.bus.session import Service

RUN = "run-test"


def frame(svc: Service, index: int, run: str = RUN, producer: str = "source",
          stream: str | None = None) -> bytes:
    header = Header.now(stream or svc.stream, index, producer, run_id=run)
    return encode(Frame.from_array(header, np.full((24, 32, 3), index % 256, np.uint8)))


def wait_until(done: Callable[[], bool], timeout: float = 20.0) -> None:
    deadline = time.monotonic() + timeout
    while not done():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.01)


@pytest.fixture
def sink_bus(bus_pair: tuple[BusOptions, BusOptions]) -> BusOptions:
    return bus_pair[1].replace(run_id=RUN)


def test_inbox_keeps_the_latest_and_counts_what_it_overwrote(
    peer: Service, sink_bus: BusOptions
) -> None:
    with Service("sink", sink_bus, handle_signals=False) as sink:
        inbox = sink.inbox("frame", capacity=2)
        sink.ready()
        assert peer.wait_for_alive(["sink"], 60) == []
        for i in range(6):
            peer.put(peer.key("frame"), frame(peer, i), MUST_ARRIVE)
        wait_until(lambda: inbox.dropped + inbox.pending() == 6)
        got = [inbox.get(1.0), inbox.get(1.0)]
        assert [g.message.header.frame_index for g in got] == [4, 5]
        assert inbox.dropped == 4 and sink.stats.dropped == 4
        assert sink.stats.frames_in == 2 and sink.stats.last_frame == 5
        assert inbox.get(0.05) is None


def test_a_flood_of_invalid_and_foreign_messages_displaces_no_real_frame(
    peer: Service, sink_bus: BusOptions
) -> None:
    invalid, foreign = 10_000, 1_000
    with Service("sink", sink_bus, handle_signals=False) as sink:
        inbox = sink.inbox("frame", capacity=2)
        sink.ready()
        assert peer.wait_for_alive(["sink"], 60) == []
        key = peer.key("frame")
        peer.put(key, frame(peer, 0), MUST_ARRIVE)
        for k in range(invalid):
            peer.put(key, b"\x93garbage" + k.to_bytes(4, "little"), MUST_ARRIVE)
            if k % 10 == 0 and k // 10 < foreign // 2:
                peer.put(key, frame(peer, 0, run="run-other"), MUST_ARRIVE)
                peer.put(key, frame(peer, 1, producer="intruder"), MUST_ARRIVE)
        peer.put(key, frame(peer, 1), MUST_ARRIVE)
        wait_until(lambda: sink.stats.rejected + sink.stats.ignored + inbox.pending()
                   == invalid + foreign + 2)
        assert [inbox.get(1.0).message.header.frame_index for _ in range(2)] == [0, 1]
        assert inbox.dropped == 0
        assert sink.stats.rejected == invalid and sink.stats.ignored == foreign


def test_rejected_messages_are_counted_and_each_reason_logged_once(
    peer: Service, sink_bus: BusOptions, caplog: pytest.LogCaptureFixture
) -> None:
    eos = EndOfStream(Header.now(peer.stream, 0, "source", run_id=RUN), 1, "end_of_file")
    with caplog.at_level(logging.WARNING), Service("sink", sink_bus,
                                                   handle_signals=False) as sink:
        inbox = sink.inbox("frame", capacity=16)
        sink.ready()
        assert peer.wait_for_alive(["sink"], 60) == []
        for payload in [b"\x00garbage", b"\x01garbage", encode(eos), b"",
                        frame(peer, 3, stream="elsewhere")]:
            peer.put(peer.key("frame"), payload, MUST_ARRIVE)
        peer.put(peer.key("frame"), frame(peer, 7), MUST_ARRIVE)
        got = inbox.get(60.0)
        assert got is not None and got.message.header.frame_index == 7
        assert sink.stats.rejected == 5
    lines = [r.getMessage() for r in caplog.records if "rejected input" in r.getMessage()]
    # The two garbage payloads differ only in a byte: one reason, logged once.
    assert len(lines) == 4, lines
    assert any("expected 'frame', got 'eos'" in line for line in lines)
    assert any("stream 'elsewhere'" in line for line in lines)


def test_gaps_in_a_runs_frame_numbers_are_counted_as_lost(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions]
) -> None:
    with Service("sink", bus_pair[1], handle_signals=False) as sink:  # follows any run
        inbox = sink.inbox("frame", capacity=32, count_lost=True)
        others = sink.latest("frame")  # counts nothing: frames it misses are dropped by design
        sink.ready()
        assert peer.wait_for_alive(["sink"], 60) == []
        for run, index in [("run-a", 0), ("run-a", 1), ("run-a", 3), ("run-a", 6),
                           ("run-b", 0), ("run-b", 2)]:
            peer.put(peer.key("frame"), frame(peer, index, run=run), MUST_ARRIVE)
        wait_until(lambda: inbox.pending() == 6 and others.peek() is not None)
        assert sink.stats.lost == 2 + 1 + 1  # a: 2, 4, 5; b: 1


def test_latest_and_recent_keep_what_they_promise(
    peer: Service, sink_bus: BusOptions
) -> None:
    with Service("sink", sink_bus, handle_signals=False) as sink:
        latest = sink.latest("frame")
        recent = sink.recent("frame", 3)
        sink.ready()
        assert peer.wait_for_alive(["sink"], 60) == []
        for i in range(5):
            peer.put(peer.key("frame"), frame(peer, i), MUST_ARRIVE)
        wait_until(lambda: (m := latest.peek()) is not None and m.header.frame_index == 4)
        assert latest.take().message.header.frame_index == 4 and latest.take() is None
        wait_until(lambda: recent.take(RUN, 4) is not None)
        assert recent.take(RUN, 0) is None  # pushed out
        assert recent.take(RUN, 3).message.header.frame_index == 3
        assert recent.take("run-other", 2) is None


def test_recent_waits_for_a_message_that_is_still_on_its_way(
    peer: Service, sink_bus: BusOptions
) -> None:
    with Service("sink", sink_bus, handle_signals=False) as sink:
        recent = sink.recent("frame", 3)
        sink.ready()
        assert peer.wait_for_alive(["sink"], 60) == []
        started = time.monotonic()
        assert recent.take(RUN, 7, timeout=0.2) is None  # never sent: waited for, then None
        assert time.monotonic() - started >= 0.2
        later = threading.Timer(0.3, lambda: peer.put(peer.key("frame"), frame(peer, 8),
                                                      MUST_ARRIVE))
        later.start()
        got = recent.take(RUN, 8, timeout=20.0)  # sent while waiting
        later.join()
        assert got is not None and got.message.header.frame_index == 8
        recent.wake()
        started = time.monotonic()
        assert recent.take(RUN, 9, timeout=60.0) is None
        assert time.monotonic() - started < 30.0  # woken: it did not wait its timeout out
