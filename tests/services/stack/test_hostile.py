"""A program of the same user on a run's bus, without the run's keys: every attack of issue 37
in one real run, each message ignored and counted by its reason, and the run complete with
exit code 0.

The attacks go out once the run's fits flow; the test then waits until the launcher has
counted every one of them (they are sent so that they arrive), so the counts do not depend
on how the attack and the run interleave.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from proto import EndOfStream, Fit, Frame, Header, Status, decode, encode
from proto.auth import Keyring
from services.bus.connection import BusOptions
from services.bus.qos import MUST_ARRIVE
from services.bus.session import Service
from services.stack.launcher import Stack
from services.stack.options import StackOptions
from services.stack.outcome import exit_code


def _wait(condition: Callable[[], bool], what: str, timeout: float = 90.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, what
        time.sleep(0.05)


def _status(stream: str, run: str, service: str) -> Status:
    return Status(Header.now(stream, 5, service, run_id=run), service=service, state="running",
                  frames_in=5, frames_out=5, dropped=100_000, rejected=0, lost=0, ignored=0,
                  failed=0, latency_p50_ms=1.0, latency_p99_ms=2.0, restarts=77, message="")


def _fit(stream: str, run: str, index: int, points: int = 68, faces: int = 1) -> Fit:
    landmarks = np.full((points, 2), 100.0, np.float32) + np.arange(points)[:, None]
    return Fit(Header.now(stream, index, "fitter", run_id=run), "ibug68", landmarks,
               np.array([1.0, 0.0, 0.0, 0.0], np.float32), 640, 360, False, "", 0.5, "none",
               None, faces=faces)


def attacks(intruder: Service, run: str, frames: list[bytes]) -> dict[str, int]:
    """Send every attack; how many messages the launcher must ignore, by reason (the forged
    and replayed frames are the fitter's to ignore)."""
    stream, sent = intruder.stream, {}

    def put(reason: str, key: str, payload: bytes) -> None:
        intruder.put(key, payload, MUST_ARRIVE)
        if not key.endswith("/frame"):  # the launcher takes no frames: the fitter counts them
            sent[reason] = sent.get(reason, 0) + 1

    status_key = f"aamtrack/{stream}/status/"
    other_run = Keyring.generate(["source", "fitter"])
    for k in range(5):
        real = decode(frames[k], "frame")
        black = Frame.from_array(real.header, np.zeros((real.height, real.width, 3), np.uint8))
        put("bad signature", intruder.key("frame"), encode(black))  # its header, other pixels
        put("replayed", intruder.key("frame"), frames[k])  # the very frame, again
        put("unsigned", status_key + "fitter", encode(_status(stream, run, "fitter")))
        put("unsigned", intruder.key("fit"), encode(_fit(stream, run, real.header.frame_index)))
        put("unsigned", intruder.key("fit"),  # three landmarks and two faces
            encode(_fit(stream, run, real.header.frame_index, points=3, faces=2)))
        put("bad signature", intruder.key("fit"),
            Keyring(other_run.keys, "fitter").encode(_fit(stream, run, 10_000_000 + k)))
        put("not a service of the run", status_key + "ghost",
            encode(_status(stream, run, "ghost")))
        put("another run", status_key + "fitter",
            encode(_status(stream, "run-000000000000", "fitter")))
    eos = EndOfStream(Header.now(stream, 9, "source", run_id=run), 10, "end_of_file")
    put("unsigned", intruder.key("eos"), encode(eos))
    put("another run", intruder.key("eos"), encode(replace(eos, header=replace(
        eos.header, run_id="run-other"))))
    put("not its key's owner", intruder.key("eos"), encode(replace(eos, header=replace(
        eos.header, producer="intruder"))))
    cut = Keyring(other_run.keys, "source").encode(eos)
    auth = decode(cut).header.auth
    intruder.put(intruder.key("eos"), cut.replace(b"\xd9\x20" + auth.encode(),
                                                  b"\xbf" + auth[:31].encode(), 1), MUST_ARRIVE)
    return sent


def test_every_attack_without_the_keys_is_ignored_counted_and_the_run_exits_0(
    single_face: Path, stack_options: Callable[..., StackOptions],
) -> None:
    opts = stack_options(single_face, ar=False, loop=3)  # fast: every frame answered
    frames: list[bytes] = []
    lock = threading.Lock()

    def capture(sample: object) -> None:
        with lock:
            if len(frames) < 5:
                frames.append(sample.payload.to_bytes())  # type: ignore[attr-defined]

    with Stack(opts) as stack, Service(
            "intruder", BusOptions(opts.launch.stream, listen=("tcp/127.0.0.1:0",),
                                   connect=(stack.endpoint,)), handle_signals=False,
            announce=False) as intruder:
        intruder.subscribe(intruder.key("frame"), capture)
        _wait(lambda: len(frames) >= 5 and stack.monitor.counts["fit"] >= 5, "no fits")
        sent = attacks(intruder, stack.run_id, frames)
        ignored = stack.service.stats.ignored_by
        _wait(lambda: all(ignored[r] >= n for r, n in sent.items())
              and stack.service.stats.rejected >= 1, f"not all counted: {ignored} of {sent}")
        outcome = stack.wait()
    summary = stack.summary()
    total = summary["total_frames"]
    assert outcome == "done" and total == 216 and exit_code(outcome, summary) == 0, summary
    assert summary["frames_with"]["fit"] == summary["frames_with"]["pose"] == total
    assert summary["messages"]["fit"] == total  # no forged fit counted as the run's
    assert summary["unanswered"] == {"fit": 0, "pose": 0}
    for reason, n in sent.items():  # by reason, in the summary (the replays of the real
        assert summary["ignored"][reason] >= n, (reason, summary["ignored"])  # run count too)
    assert summary["rejected"] >= 1  # the truncated signature
    fitter, expression = summary["services"]["fitter"], summary["services"]["expression"]
    assert fitter["restarts"] == 0 and fitter["dropped"] < 100_000
    assert fitter["ignored"] >= 10 and fitter["lost"] == 0  # the forged and replayed frames
    assert expression["state"] != "degraded", expression  # a forged fit cannot degrade it
