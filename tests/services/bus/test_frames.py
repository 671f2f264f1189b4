"""services.bus.frames: frames kept for the results to come, within a count and a byte bound,
over a real Zenoh session."""

from __future__ import annotations

import time
from collections.abc import Iterator

import numpy as np
import pytest

from proto import Frame, Header
from services.bus.connection import BusOptions
from services.bus.frames import FrameStore
from services.bus.session import Service


@pytest.fixture()
def svc() -> Iterator[Service]:
    with Service("source", BusOptions("frames"), handle_signals=False, announce=False) as s:
        yield s


def publish(svc: Service, indices: range, side: int = 10, run: str = "") -> None:
    for i in indices:
        header = Header.now(svc.stream, i, "source", run_id=run)
        svc.publish(Frame.from_array(header, np.full((side, side, 3), i % 256, np.uint8)))


def wait_for(store: FrameStore, index: int, run: str = "") -> None:
    deadline = time.monotonic() + 10
    while store.take(run, index, keep=True) is None:
        assert time.monotonic() < deadline, f"frame {index} did not arrive"
        time.sleep(0.01)


def test_the_oldest_frames_are_pushed_out_past_the_count_and_counted(svc: Service) -> None:
    store = svc.frame_store(count=8)
    publish(svc, range(20))
    wait_for(store, 19)
    assert len(store) == 8 and store.pushed_out == 12
    assert store.take("", 11) is None and store.take("", 12) is not None


def test_the_byte_bound_holds_whatever_the_count(svc: Service) -> None:
    frame_bytes = 100 * 100 * 3
    store = svc.frame_store(count=1000, max_bytes=5 * frame_bytes)
    publish(svc, range(12), side=100)
    wait_for(store, 11)
    assert len(store) == 5 and store.kept_bytes == 5 * frame_bytes
    assert store.pushed_out == 7
    image = store.take("", 11).message.image
    assert image.shape == (100, 100, 3) and (image == 11).all()


def test_frames_of_an_earlier_run_are_forgotten_with_the_first_result_of_a_new_one(
        svc: Service) -> None:
    store = svc.frame_store()
    publish(svc, range(5), run="run-a")
    wait_for(store, 4, "run-a")
    publish(svc, range(3), run="run-b")
    wait_for(store, 2, "run-b")
    assert store.forget_before("run-b", 1) == 6  # five of run-a, frame 0 of run-b
    assert len(store) == 2 and store.take("run-a", 4) is None
