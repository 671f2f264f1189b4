"""services.stack.monitor: the launcher's accounting comes from messages signed by the run's
services only, so no program without the keys can talk a lossy run into success.

The monitor is fed samples directly (no bus, no timing): a run of 10 frames whose fitter
answered 5, then forged statuses and fits in the fitter's name.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from proto import EndOfStream, Fit, Header, Status, encode
from proto.auth import Keyring
from services.bus.connection import BusOptions
from services.bus.session import Service
from services.stack.monitor import StackMonitor, summary_table
from services.stack.outcome import EXIT_FAILED, exit_code

RUN = "run-test"
RING = Keyring.generate(["source", "fitter", "launcher"])


@dataclass
class _Payload:
    data: bytes

    def to_bytes(self) -> bytes:
        return self.data


@dataclass
class _Sample:
    key_expr: str
    payload: _Payload


def _fit(index: int, failed: bool = False) -> Fit:
    landmarks = np.zeros((0 if failed else 68, 2), np.float32) + 50
    return Fit(Header.now("cam0", index, "fitter", run_id=RUN), "ibug68", landmarks,
               np.array([1.0, 0, 0, 0], np.float32), 64, 48, failed, "no face" if failed else "",
               0.5, "none", None)


def _status(dropped: int, restarts: int, run: str = RUN) -> Status:
    return Status(Header.now("cam0", 4, "fitter", run_id=run), service="fitter",
                  state="running", frames_in=5, frames_out=5, dropped=dropped, rejected=0,
                  lost=0, ignored=0, failed=0, latency_p50_ms=1.0, latency_p99_ms=2.0,
                  restarts=restarts, message="")


def test_forged_statuses_and_fits_cannot_talk_a_lossy_run_into_success() -> None:
    svc = Service("launcher", BusOptions("cam0", run_id=RUN),
                  keyring=RING.for_service("launcher"))
    monitor = StackMonitor(svc, None, False)

    def feed(key: str, payload: bytes) -> None:
        monitor._on_sample(_Sample(f"aamtrack/cam0/{key}", _Payload(payload)))

    fitter, source = RING.for_service("fitter"), RING.for_service("source")
    for k in range(5):
        feed("fit", fitter.encode(_fit(k)))
    feed("status/fitter", fitter.encode(_status(dropped=0, restarts=0)))
    eos = EndOfStream(Header.now("cam0", 9, "source", run_id=RUN), 10, "end_of_file")
    feed("eos", source.encode(eos))
    other = Keyring.generate(["fitter"]).for_service("fitter")
    for k in range(5, 10):  # the forger's "no face" fits and counts of the issue
        feed("fit", encode(_fit(k, failed=True)))
        feed("fit", other.encode(_fit(k, failed=True)))
        feed("status/fitter", encode(_status(dropped=100_000, restarts=77)))
        feed("status/fitter", other.encode(_status(dropped=100_000, restarts=77)))
        feed("status/fitter", fitter.encode(_status(dropped=100_000, restarts=77,
                                                    run="run-000000000000")))
        feed("fit", fitter.encode(_fit(k - 5)))  # a real fit, again
    feed("eos", source.encode(eos))
    summary = monitor.summary()
    assert summary["frames_with"]["fit"] == 5 and summary["unanswered"]["fit"] == 5
    assert summary["services"]["fitter"]["dropped"] == 0
    assert summary["services"]["fitter"]["restarts"] == 0
    assert exit_code("done", summary) == EXIT_FAILED
    assert summary["ignored"] == {"unsigned": 10, "bad signature": 10, "another run": 5,
                                  "replayed": 6}
    table = summary_table(summary)
    assert ("not the run's, seen by the launcher and ignored: 5 another run, 10 bad signature, "
            "6 replayed, 10 unsigned") in table
