"""Hostile and careless peers of a real run, each case a function that runs one stack and says
whether the run came through (bench/bench_reliability.py runs each many times).

Every case runs the default services on ``single_face.mp4`` in real time, with a peer
on the same bus doing something it should not:

- ``extreme fits``: 60 well-formed fits with landmarks a pixel or two apart on frames of any
  shape, on the fit key, while the run goes on: the pose service must not restart.
- ``forged frame 0``: unsigned frames of another size numbered 0 (and 900000), as the
  run's own source, from before the source starts: every real frame must get its fit.
- ``forged end``: an unsigned end of stream as the run's source at frame 10: the run must
  go on to its real end.
- ``pose killed``: the pose service killed mid-run: the fits it missed are counted and the
  run exits 1 saying so.
- ``other user``: a probe run as user ``nobody`` must not connect to any of the run's
  sockets (root only; skipped otherwise);
- the attacks of issue 37, with and without access to the run's processes
  (:mod:`reliability_attacks`).
"""

from __future__ import annotations

import functools
import itertools
import json
import os
import signal
import subprocess
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from bench.reliability_attacks import ATTACKS
from proto import EndOfStream, Fit, Frame, Header, encode
from services.bus.connection import BusOptions
from services.bus.qos import MUST_ARRIVE
from services.bus.runtime import socket_path
from services.bus.session import Service
from services.stack.launcher import Stack, prepared
from services.stack.options import parse_run_args
from services.stack.outcome import EXIT_FAILED, exit_code

Case = Callable[[list[str]], tuple[bool, str]]


def _intruder(stack: Stack) -> Service:
    bus = BusOptions(stack.opts.launch.stream, listen=("tcp/127.0.0.1:0",),
                     connect=(stack.endpoint,))
    return Service("intruder", bus, handle_signals=False, announce=False)


def _run(argv: list[str], during: Callable[[Stack, Service], None],
         after: Callable[[Stack, Service], None] | None = None) -> tuple[Stack, dict]:
    opts = prepared(parse_run_args([*argv, "--pace", "realtime", "--loop", "3"]))
    with Stack(opts) as stack, _intruder(stack) as intruder:
        during(stack, intruder)
        stack.wait()
        if after is not None:
            after(stack, intruder)
    return stack, stack.summary()


def _wait(condition: Callable[[], bool], timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.02)


def extreme_fits(argv: list[str]) -> tuple[bool, str]:
    def during(stack: Stack, intruder: Service) -> None:
        _wait(lambda: stack.monitor.counts["pose"] >= 5)
        rng = np.random.default_rng()
        for k in range(60):
            w, h = (int(v) for v in rng.integers(16, 4096, size=2))
            points = rng.uniform([0, 0], [w, h]) + rng.standard_normal((68, 2))
            fit = Fit(Header.now(intruder.stream, 100_000 + k, "fitter", run_id=stack.run_id),
                      "ibug68", points.astype(np.float32), np.ones(4, np.float32), w, h, False,
                      "", 0.5, "none", None)
            intruder.put(intruder.key("fit"), encode(fit), MUST_ARRIVE)
            time.sleep(0.02)

    _, summary = _run(argv, during)
    pose = summary["services"]["pose"]
    ok = pose["restarts"] == 0 and summary["outcome"] == "done"
    return ok, f"pose restarts {pose['restarts']}, failed {pose['failed']}"


def forged_frame_zero(argv: list[str]) -> tuple[bool, str]:
    def during(stack: Stack, intruder: Service) -> None:
        image = np.zeros((24, 32, 3), np.uint8)
        deadline = time.monotonic() + 120
        for k in itertools.count():  # from before the source's first frame until fits flow
            if stack.monitor.counts["fit"] >= 20 or time.monotonic() > deadline:
                break
            index = 0 if k % 2 else 900_000 + k
            forged = Header.now(intruder.stream, index, "source", run_id=stack.run_id)
            intruder.put(intruder.key("frame"), encode(Frame.from_array(forged, image)))
            time.sleep(0.01)

    _, summary = _run(argv, during)
    fitter = summary["services"]["fitter"]
    ok = summary["unanswered"]["fit"] == 0 and fitter["ignored"] > 0
    return ok, (f"{summary['frames_with']['fit']} of {summary['total_frames']} frames fitted, "
                f"{fitter['ignored']} forged frames ignored")


def forged_end(argv: list[str]) -> tuple[bool, str]:
    def during(stack: Stack, intruder: Service) -> None:
        _wait(lambda: stack.monitor.counts["fit"] >= 10)
        eos = EndOfStream(Header.now(intruder.stream, 5, "source", run_id=stack.run_id), 6,
                          "end_of_file")
        intruder.put(intruder.key("eos"), encode(eos), MUST_ARRIVE)

    _, summary = _run(argv, during)
    ok = (summary["total_frames"] == 216 and summary["unanswered"]["fit"] == 0
          and summary["ignored"].get("unsigned", 0) >= 1)
    return ok, (f"end of stream at {summary['total_frames']} frames, unanswered "
                f"{summary['unanswered']}, {summary['ignored'].get('unsigned', 0)} unsigned "
                "ignored")


def pose_killed(argv: list[str]) -> tuple[bool, str]:
    def during(stack: Stack, intruder: Service) -> None:
        _wait(lambda: stack.monitor.counts["pose"] >= 10)
        pid = stack.supervisor.pid("pose")
        if pid is not None:
            os.kill(pid, signal.SIGKILL)

    _, summary = _run(argv, during)
    owed = summary["unanswered"]["pose"]
    ok = owed > 0 and exit_code("done", summary) == EXIT_FAILED
    return ok, f"{owed} fits without a pose counted, exit {exit_code('done', summary)}"


PROBE = ("import json, socket, sys\nout = {}\nfor p in json.loads(sys.argv[1]):\n"
         "    s = socket.socket(socket.AF_UNIX)\n    try:\n        s.connect(p); out[p] = 'in'\n"
         "    except OSError as e:\n        out[p] = type(e).__name__\nprint(json.dumps(out))\n")


def other_user(argv: list[str]) -> tuple[bool, str]:
    if os.geteuid() != 0 or not Path("/usr/bin/python3").exists():
        return True, "skipped (needs root and /usr/bin/python3)"
    seen: dict[str, str] = {}

    def during(stack: Stack, intruder: Service) -> None:
        launcher = socket_path(stack.endpoint)
        assert launcher is not None
        _wait(lambda: len(list(launcher.parent.glob(f"{stack.run_id}-*.sock")))
              == len(stack.specs))
        paths = [str(launcher), *map(str, launcher.parent.glob(f"{stack.run_id}-*.sock"))]
        done = subprocess.run(["/usr/bin/python3", "-c", PROBE, json.dumps(paths)],
                              capture_output=True, text=True, timeout=30, user=65534, cwd="/")
        seen.update(json.loads(done.stdout or "{}"))

    _run(argv, during)
    ok = bool(seen) and all(v == "PermissionError" for v in seen.values())
    return ok, f"{len(seen)} sockets probed as nobody: {sorted(set(seen.values()))}"


CASES: dict[str, Case] = {"extreme fits": extreme_fits, "forged frame 0": forged_frame_zero,
                          "forged end": forged_end, "pose killed": pose_killed,
                          "other user": other_user} | {
    name: functools.partial(attack, _run) for name, attack in ATTACKS.items()}
"""Every case: those above, then the attacks of issue 37 (:mod:`reliability_attacks`)."""
