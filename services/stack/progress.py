"""The progress of a run on a video file: frames fitted of the frames it holds, frames per
second and time left (a bar on a terminal, a line every few seconds elsewhere;
:mod:`aamcore.progress`). Runs on a camera or a stream URL, or looping without end, show
none."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from services.stack.monitor import StackMonitor
    from services.stack.options import StackOptions

POLL_S = 0.5
"""Seconds between two reads of the monitor's count."""


@contextmanager
def run_progress(opts: StackOptions, monitor: StackMonitor) -> Iterator[None]:
    """Show the frames the run has fitted while the body runs."""
    from aamcore.io.video import video_facts
    from aamcore.progress import Meter, mode

    source = opts.services.get("source")
    video = getattr(source, "video", None)
    loops = getattr(source, "loop", 1)
    if video is None or not loops or mode() == "off":
        yield
        return
    frames = video_facts(video)[0] * loops
    meter = Meter(f"running the stack on {Path(video).name}", frames, "frame", summary=False)
    stop = threading.Event()

    def poll() -> None:
        while not stop.wait(POLL_S):
            meter.update(len(monitor.indices["fit"]))

    poller = threading.Thread(target=poll, name="run-progress", daemon=True)
    poller.start()
    try:
        yield
    finally:
        stop.set()
        poller.join()
        meter.update(len(monitor.indices["fit"]))
        meter.close()
