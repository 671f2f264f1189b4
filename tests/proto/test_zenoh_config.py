"""The Zenoh configuration helper, and a real round trip of encoded messages over Zenoh."""

from __future__ import annotations

import json
import socket
import time

import numpy as np
import pytest
import zenoh

from proto.codec import decode, encode
from proto.header import Header
from proto.keys import parse_key, stream_wildcard
from proto.messages import Frame, Message
from proto.zenoh_config import DROP_WAIT_US, zenoh_config


def free_tcp_endpoint() -> str:
    """A ``tcp/127.0.0.1:<port>`` endpoint on a port that was free a moment ago."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{sock.getsockname()[1]}"


def test_config_sets_mode_endpoints_and_scouting() -> None:
    config = zenoh_config("client", connect=["tcp/10.0.0.1:7447"])
    assert json.loads(config.get_json("mode")) == "client"
    assert json.loads(config.get_json("connect/endpoints")) == ["tcp/10.0.0.1:7447"]
    drop = json.loads(config.get_json("transport/link/tx/queue/congestion_control/drop"))
    assert drop == DROP_WAIT_US  # a loaded machine's queue gets time before anything drops
    assert json.loads(config.get_json("listen/endpoints")) == []
    assert json.loads(config.get_json("scouting/multicast/enabled")) is False
    assert json.loads(zenoh_config(multicast_scouting=True).get_json("scouting/multicast/enabled"))


@pytest.mark.parametrize(
    ("kwargs", "reason"),
    [
        ({"mode": "broker"}, "mode 'broker'"),
        ({"listen": ["127.0.0.1:7447"]}, "endpoint '127.0.0.1:7447'"),
        ({"connect": ["tcp/"]}, "endpoint 'tcp/'"),
    ],
)
def test_config_rejects_bad_mode_and_endpoints(kwargs: dict, reason: str) -> None:
    with pytest.raises(ValueError, match=reason):
        zenoh_config(**kwargs)


def wait_until(condition, timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(0.01)


def test_fit_and_frame_travel_over_a_real_zenoh_link(golden: dict[str, Message]) -> None:
    endpoint = free_tcp_endpoint()
    rng = np.random.default_rng(0)
    frame = Frame.from_array(
        Header.now("cam0", 42, "capture"), rng.integers(0, 256, (480, 640, 3), dtype=np.uint8)
    )
    sent = {"fit": golden["fit"], "frame": frame}
    with (
        zenoh.open(zenoh_config("peer", listen=[endpoint])) as publisher_side,
        zenoh.open(zenoh_config("peer", connect=[endpoint])) as subscriber_side,
    ):
        subscriber = subscriber_side.declare_subscriber(
            stream_wildcard("cam0"), zenoh.handlers.FifoChannel(8)
        )
        publishers = [publisher_side.declare_publisher(msg.key()) for msg in sent.values()]
        try:
            wait_until(
                lambda: all(p.matching_status.matching for p in publishers), 10, "the subscriber"
            )
            for publisher, msg in zip(publishers, sent.values(), strict=True):
                publisher.put(encode(msg))
            received: dict[str, Message] = {}

            def take() -> bool:
                sample = subscriber.try_recv()
                if sample is not None:
                    stream, kind, _ = parse_key(str(sample.key_expr))
                    assert stream == "cam0"
                    received[kind] = decode(sample.payload.to_bytes(), expected_kind=kind)
                return len(received) == len(sent)

            wait_until(take, 10, "both messages")
        finally:
            for publisher in publishers:
                publisher.undeclare()
            subscriber.undeclare()
    assert received == sent
    assert received["frame"].image.shape == (480, 640, 3)
    np.testing.assert_array_equal(received["fit"].landmarks, golden["fit"].landmarks)
