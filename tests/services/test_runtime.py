"""services.bus.runtime: options, inboxes, rejection counts, status and liveliness on a real bus."""

from __future__ import annotations

import logging
import signal
import time

import cv2
import numpy as np
import pytest

from proto import EndOfStream, Frame, Header, ProtoError, encode
from proto.keys import status_key
from services.bus.runtime import (
    BusOptions,
    Service,
    add_bus_arguments,
    alive_services,
    image_of,
    service_parser,
)


def _frame(svc: Service, index: int, shape: tuple[int, ...] = (48, 64, 3)) -> Frame:
    return Frame.from_array(svc.header(index), np.full(shape, index % 256, np.uint8))


def test_bus_options_from_environment_and_back_to_argv(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("AAMTRACK_STREAM", "camA")
    monkeypatch.setenv("AAMTRACK_ZENOH_CONNECT", "tcp/127.0.0.1:7000, tcp/127.0.0.1:7001")
    parser = service_parser("x", "test")
    opts = BusOptions.from_args(parser.parse_args(["--listen", "tcp/127.0.0.1:0"]))
    assert opts == BusOptions("camA", "peer", ("tcp/127.0.0.1:0",),
                              ("tcp/127.0.0.1:7000", "tcp/127.0.0.1:7001"))
    assert BusOptions.from_args(parser.parse_args(opts.argv())) == opts


def test_bus_options_reject_bad_names_and_modes() -> None:
    with pytest.raises(ValueError, match="stream id"):
        BusOptions("a/b")
    with pytest.raises(ValueError, match="zenoh mode"):
        BusOptions("cam0", mode="hub")
    with pytest.raises(ValueError, match="endpoint"):
        BusOptions("cam0", connect=("localhost",)).config()


def test_add_bus_arguments_without_verbose() -> None:
    import argparse

    parser = argparse.ArgumentParser()
    add_bus_arguments(parser, verbose=False)
    assert not hasattr(parser.parse_args([]), "verbose")


def test_inbox_keeps_the_latest_and_counts_what_it_overwrote(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions]
) -> None:
    with Service("sink", bus_pair[1], handle_signals=False) as sink:
        inbox = sink.inbox("frame", capacity=2)
        sink.ready()
        assert peer.wait_for_alive(["sink"], 10) == []
        for i in range(6):
            peer.publish(_frame(peer, i))
        deadline = time.monotonic() + 5
        while inbox.dropped + inbox.pending() < 6 and time.monotonic() < deadline:
            time.sleep(0.02)
        got = [inbox.get(1.0), inbox.get(1.0)]
        assert [g.message.header.frame_index for g in got] == [4, 5]
        assert inbox.dropped == 4 and sink.stats.dropped == 4
        assert sink.stats.frames_in == 2 and sink.stats.last_frame == 5
        assert inbox.get(0.05) is None


def test_rejected_messages_are_counted_and_each_reason_logged_once(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions], caplog: pytest.LogCaptureFixture
) -> None:
    eos = EndOfStream(Header.now("other", 0, "x"), total_frames=1, reason="end_of_file")
    with caplog.at_level(logging.WARNING), Service("sink", bus_pair[1],
                                                   handle_signals=False) as sink:
        inbox = sink.inbox("frame", capacity=16)
        sink.ready()
        assert peer.wait_for_alive(["sink"], 10) == []
        for payload in [b"\x00garbage", b"\x01garbage", encode(eos), b""]:
            peer.put(peer.key("frame"), payload)
        peer.publish(_frame(peer, 7))
        got = inbox.get(5.0)
        assert got is not None and got.message.header.frame_index == 7
        assert sink.stats.rejected == 4
    lines = [r.getMessage() for r in caplog.records if "rejected input" in r.getMessage()]
    # The two garbage payloads differ only in a byte: one reason, logged once.
    assert len(lines) == 3, lines
    assert any("expected 'frame', got 'eos'" in line for line in lines)


def test_status_is_published_every_period_and_liveliness_follows_ready(
    peer: Service, bus_pair: tuple[BusOptions, BusOptions]
) -> None:
    statuses = peer.inbox(status_key(peer.stream, "sink"), capacity=32, kind="status")
    with Service("sink", bus_pair[1], status_period=0.2, handle_signals=False) as sink:
        assert "sink" not in alive_services(peer.session, peer.stream, 0.5)
        sink.stats.frames_in = 3
        sink.ready("all set")
        assert peer.wait_for_alive(["sink"], 10) == []
        first = statuses.get(5.0)
        assert first is not None and first.message.service == "sink"
        time.sleep(0.5)
    seen = []
    while (got := statuses.get(1.0)) is not None:
        seen.append(got.message)
    assert seen[-1].state == "stopped" and seen[-1].frames_in == 3
    assert any(s.state == "running" and s.message == "all set" for s in seen)
    deadline = time.monotonic() + 5
    while "sink" in alive_services(peer.session, peer.stream, 0.5):
        assert time.monotonic() < deadline, "the liveliness token outlived the session"


def test_signal_handlers_are_installed_and_restored(
    bus_pair: tuple[BusOptions, BusOptions],
) -> None:
    before = signal.getsignal(signal.SIGTERM)
    with Service("sig", bus_pair[0]) as svc:
        assert signal.getsignal(signal.SIGTERM) != before
        signal.raise_signal(signal.SIGTERM)
        assert svc.stopping
    assert signal.getsignal(signal.SIGTERM) == before


def test_image_of_decodes_jpeg_and_checks_its_size() -> None:
    image = np.zeros((40, 60, 3), np.uint8)
    image[10:30, 20:40] = 200
    data = cv2.imencode(".jpg", image)[1].tobytes()
    header = Header.now("cam0", 0, "x")
    decoded = image_of(Frame.from_jpeg(header, data, 60, 40))
    assert decoded.shape == (40, 60, 3) and abs(int(decoded[20, 30, 0]) - 200) < 8
    with pytest.raises(ProtoError, match="message says 61 x 40"):
        image_of(Frame.from_jpeg(header, data, 61, 40))
    with pytest.raises(ProtoError, match="does not decode"):
        image_of(Frame.from_jpeg(header, b"\xff\xd8\xff" + b"\x00" * 20, 60, 40))
