"""services.bus.session: status, liveliness, the service loop and stop signals on a real bus."""

from __future__ import annotations

import os
import signal
import threading
import time

import numpy as np
import pytest

from proto import Frame, Header, encode
from proto.keys import status_key
from services.bus.connection import BusOptions
from services.bus.qos import MUST_ARRIVE
from services.bus.session import Service


def frame(svc: Service, index: int, kind_run: str = "") -> bytes:
    header = Header.now(svc.stream, index, "source", run_id=kind_run)
    return encode(Frame.from_array(header, np.zeros((8, 8, 3), np.uint8)))


def test_status_is_published_every_period_and_liveliness_follows_ready(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions]
) -> None:
    statuses = peer.inbox(status_key(peer.stream, "sink"), capacity=64, kind="status")
    peer.watch_presence()
    with Service("sink", bus_pair[1], status_period=0.2, handle_signals=False) as sink:
        first = statuses.get(5.0)  # statuses come before the service is ready...
        assert first is not None and first.message.state == "starting"
        assert "sink" not in peer.alive()  # ...but its token does not
        sink.stats.frames_in = 3
        sink.ready("all set")
        assert peer.wait_for_alive(["sink"], 10) == []
        while (got := statuses.get(5.0)) is not None and got.message.state != "running":
            pass
        assert got is not None and got.message.message == "all set"
    seen = []
    while (got := statuses.get(1.0)) is not None:
        seen.append(got.message)
    assert seen[-1].state == "stopped" and seen[-1].frames_in == 3
    deadline = time.monotonic() + 5
    while "sink" in peer.alive():
        assert time.monotonic() < deadline, "the liveliness token outlived the session"
        time.sleep(0.05)


def test_a_tool_that_does_not_announce_publishes_no_status(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions]
) -> None:
    statuses = peer.inbox(status_key(peer.stream, "tool"), capacity=8, kind="status")
    with Service("tool", bus_pair[1], status_period=0.1, handle_signals=False,
                 announce=False) as tool:
        tool.ready()
        assert peer.wait_for_alive(["tool"], 10) == []
        time.sleep(0.4)
    assert statuses.get(0.5) is None


def test_the_message_loop_yields_each_message_and_times_the_work(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions]
) -> None:
    with Service("sink", bus_pair[1], handle_signals=False) as sink:
        loop = sink.messages("frame", capacity=8)
        got = []

        def consume() -> None:
            for received in loop:
                got.append(received.message.header.frame_index)
                time.sleep(0.01)
                if len(got) == 3:
                    sink.request_stop("done")

        worker = threading.Thread(target=consume)
        worker.start()
        assert peer.wait_for_alive(["sink"], 10) == []
        for i in range(3):
            peer.put(peer.key("frame"), frame(peer, i), MUST_ARRIVE)
        worker.join(10)
        assert not worker.is_alive() and got == [0, 1, 2]
        p50, _ = sink.stats.latency.percentiles()
        assert p50 >= 10.0  # the 10 ms of work per message


def test_a_loop_over_several_inputs_yields_none_when_idle(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions]
) -> None:
    with Service("sink", bus_pair[1], handle_signals=False) as sink:
        loop = sink.messages_of({"frame": ("frame", 2), "eos": ("eos", 4)}, tick=0.05)
        assert next(loop) is None  # nothing came within a tick
        assert peer.wait_for_alive(["sink"], 10) == []
        peer.put(peer.key("frame"), frame(peer, 5), MUST_ARRIVE)
        item = next(loop)
        while item is None:
            item = next(loop)
        assert item.message.header.frame_index == 5


@pytest.mark.parametrize("signals", [(signal.SIGTERM,), (signal.SIGHUP,),
                                     (signal.SIGINT, signal.SIGTERM, signal.SIGINT)])
def test_stop_signals_only_set_a_flag_and_never_block(
    bus_pair: tuple[BusOptions, BusOptions], signals: tuple[int, ...]
) -> None:
    before = signal.getsignal(signal.SIGTERM)
    with Service("sig", bus_pair[0]) as svc:
        assert signal.getsignal(signal.SIGTERM) != before
        for sig in signals:
            os.kill(os.getpid(), sig)
        deadline = time.monotonic() + 2
        while not svc.stopping:
            assert time.monotonic() < deadline
            time.sleep(0.01)
    assert signal.getsignal(signal.SIGTERM) == before


def test_a_busy_endpoint_is_a_clear_error(bus_pair: tuple[BusOptions, BusOptions]) -> None:
    from services.bus.options import OptionError

    with Service("first", bus_pair[0], handle_signals=False), pytest.raises(
            OptionError, match="cannot open the Zenoh session"):
        Service("second", bus_pair[0], handle_signals=False).open()


def test_publishing_after_close_sends_nothing_and_raises_nothing(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions]
) -> None:
    # A queryable or subscriber callback may still answer while its service stops.
    got = peer.inbox("frame", capacity=8)
    with Service("source", bus_pair[1], handle_signals=False) as svc:
        deadline = time.monotonic() + 10
        while got.get(0.1) is None:  # until the peers have found each other
            assert time.monotonic() < deadline, "no frame arrived"
            svc.put(svc.key("frame"), frame(svc, 0))
    while got.get(0.3) is not None:  # frames sent before the close
        pass
    svc.put(svc.key("frame"), frame(svc, 1))
    svc.publish(Frame.from_array(svc.header(2), np.zeros((8, 8, 3), np.uint8)))
    assert got.get(0.5) is None
