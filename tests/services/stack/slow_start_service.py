"""A stand-in service for tests/services/stack/test_supervisor.py: slow to import, like a real one.

It writes ``importing`` to the file named by ``AAMTRACK_TEST_MARKS`` while its
module loads (for one second), then ``ready`` once its stop handlers are in,
then ``stopped: <reason>`` when a stop signal comes.
"""

from __future__ import annotations

import os
import threading
import time

from services.bus.process import StopWatch


def _mark(text: str) -> None:
    with open(os.environ["AAMTRACK_TEST_MARKS"], "a") as f:
        f.write(text + "\n")


_mark("importing")
time.sleep(1.0)


def main(argv: list[str]) -> int:
    stopped = threading.Event()
    reasons: list[str] = []
    watch = StopWatch(lambda why: (reasons.append(why), stopped.set()))
    watch.start()
    _mark("ready")
    stopped.wait(30)
    watch.close()
    _mark(f"stopped: {reasons[0] if reasons else 'timeout'}")
    return 0
