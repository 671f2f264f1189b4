"""A program of the same user on a run's bus, without the run's keys: every attack of issue 37
in one real run, each message ignored and counted by its reason, and the run complete with
exit code 0.

The attacks go out once the run's fits flow; the test then waits until the launcher has
counted every one of them (they are sent so that they arrive), so the counts do not depend
on how the attack and the run interleave.
"""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from aamcore.config import REPO_ROOT
from proto import EndOfStream, Fit, Frame, Header, HeadPose, Status, decode, encode
from proto.auth import Keyring, keys_document
from proto.golden import golden_messages
from proto.keys import detect_key, keys_key
from services.bus.connection import BusOptions
from services.bus.qos import MUST_ARRIVE
from services.bus.session import Service
from services.stack.launcher import Stack
from services.stack.options import StackOptions
from services.stack.outcome import exit_code
from services.stack.recorder import read_recording


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
            other_run.for_service("fitter").encode(_fit(stream, run, 10_000_000 + k)))
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
    cut = other_run.for_service("source").encode(eos)
    auth = decode(cut).header.auth
    intruder.put(intruder.key("eos"), cut.replace(b"\xd9\x80" + auth.encode(),
                                                  b"\xd9\x7f" + auth[:127].encode(), 1),
                 MUST_ARRIVE)
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


def _forged_pose(stream: str, run: str, index: int) -> HeadPose:
    pose = golden_messages()["pose"]
    return replace(pose, header=Header.now(stream, index, "pose", run_id=run), yaw_deg=77.0)


def _reader(*args: str) -> subprocess.Popen[str]:
    env = os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO_ROOT)}
    return subprocess.Popen([sys.executable, "-m", "services", *args], env=env, cwd=REPO_ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_readers_keep_only_the_run_s_messages_and_the_detector_s_answer_is_the_detector_s(
    single_face: Path, stack_options: Callable[..., StackOptions], tmp_path: Path,
) -> None:
    """Beside a run: a forged launcher answering for the run's keys with its own, forged poses
    (unsigned, and signed by the forged run's pose key), a rogue detector that answers every
    query with unsigned boxes at once and holds it open. ``aamtrack record --trust`` keeps
    none of the forged poses and its export has no forged row; ``echo``
    --trust prints only the run's poses; the fitter takes the detector's boxes and
    counts every rogue reply as rejected; no frame is lost."""
    opts = stack_options(single_face, ar=False, loop=3)
    # The source waits for the intruder too, so that its queryables are there from the start.
    opts = replace(opts, wait_for=(*[n for n in opts.services if n != "source"], "intruder"))
    forger = Keyring.generate(["launcher", "pose"])
    replies = [0]

    def rogue_detector(query: object) -> None:
        boxes = golden_messages()["boxes"]
        query.reply(query.key_expr, encode(boxes))  # type: ignore[attr-defined]
        replies[0] += 1
        held.append(query)  # never finalised: the query stays open until it times out

    held: list[object] = []
    with Stack(opts) as stack, Service(
            "intruder", BusOptions(opts.launch.stream, listen=("tcp/127.0.0.1:0",),
                                   connect=(stack.endpoint,)), handle_signals=False,
            announce=False) as intruder:
        document = keys_document(forger, opts.launch.stream, stack.run_id)
        intruder.queryable(keys_key(opts.launch.stream),
                           lambda q: q.reply(q.key_expr, document))  # type: ignore[attr-defined]
        intruder.queryable(detect_key(opts.launch.stream), rogue_detector)
        rec = tmp_path / "beside.rec"
        where = ["--connect", stack.endpoint, "--stream", opts.launch.stream, "--timeout", "60"]
        record = _reader("record", "--out", str(rec), "--until-eos", "--trust",
                         stack.fingerprint, *where)
        echo = _reader("echo", f"aamtrack/{opts.launch.stream}/pose", "--trust",
                       stack.fingerprint, *where)
        intruder.ready()  # the source starts
        _wait(lambda: stack.monitor.counts["pose"] >= 5, "no poses")
        sent = {"unsigned": 0, "bad signature": 0}
        for k in range(20):
            pose = _forged_pose(opts.launch.stream, stack.run_id, k)
            intruder.put(intruder.key("pose"), encode(pose), MUST_ARRIVE)
            intruder.put(intruder.key("pose"), forger.for_service("pose").encode(pose),
                         MUST_ARRIVE)
            sent = {r: n + 1 for r, n in sent.items()}
        ignored = stack.service.stats.ignored_by
        _wait(lambda: all(ignored[r] >= n for r, n in sent.items()), f"{ignored} of {sent}")
        outcome = stack.wait()
        _, record_err = record.communicate(timeout=120)
        echo.send_signal(signal.SIGINT)
        echo_out, echo_err = echo.communicate(timeout=60)
    summary = stack.summary()
    shown = echo_out.splitlines()
    assert echo.returncode == 0 and shown and stack.fingerprint in echo_err, echo_err
    assert all(line.startswith("pose") and "yaw 77.0" not in line for line in shown)
    assert outcome == "done" and exit_code(outcome, summary) == 0, summary
    assert summary["unanswered"] == {"fit": 0, "pose": 0}
    assert replies[0] >= 1  # the positive control: the fitter's queries reached the rogue
    assert summary["services"]["fitter"]["rejected"] >= replies[0]
    assert record.returncode == 0 and stack.fingerprint in record_err, record_err
    recording = read_recording(rec, trust=stack.fingerprint)
    poses = [m for m in recording.messages if m.KIND == "pose"]
    assert len(poses) == summary["frames_with"]["pose"] and poses  # every real one
    assert all(p.yaw_deg != 77.0 for p in poses)
    csv_path = tmp_path / "beside.csv"
    export = _reader("export", str(rec), "--csv", str(csv_path), "--trust", stack.fingerprint)
    _, export_err = export.communicate(timeout=120)
    assert export.returncode == 0 and "verified: run" in export_err, export_err
    rows = list(csv.DictReader(csv_path.open()))
    assert rows and all(r["verified"] == f"launcher key {stack.fingerprint}" for r in rows)
    assert not any(r["pose_yaw"] and abs(float(r["pose_yaw"]) - 77.0) < 1e-3 for r in rows)


def test_frames_a_dead_fitter_missed_stay_unanswered_whatever_is_replayed(
    single_face: Path, stack_options: Callable[..., StackOptions],
) -> None:
    """The fitter killed mid-run: every genuine frame seen so far, replayed unchanged to the
    restarted fitter, is refused ("before the restart"), and the run exits 1 with the
    frames the dead fitter missed counted unanswered."""
    opts = stack_options(single_face, ar=False, pace="realtime", loop=4)
    captured: list[bytes] = []
    lock = threading.Lock()

    def capture(sample: object) -> None:
        with lock:
            captured.append(sample.payload.to_bytes())  # type: ignore[attr-defined]

    with Stack(opts) as stack, Service(
            "intruder", BusOptions(opts.launch.stream, listen=("tcp/127.0.0.1:0",),
                                   connect=(stack.endpoint,)), handle_signals=False,
            announce=False) as intruder:
        intruder.subscribe(intruder.key("frame"), capture)
        _wait(lambda: stack.monitor.counts["fit"] >= 10, "no fits")
        pid = stack.supervisor.pid("fitter")
        assert pid is not None
        os.kill(pid, signal.SIGKILL)
        incarnations = stack.monitor.incarnations

        def restarted() -> bool:
            stack.supervisor.check()  # what Stack.wait() does: notice the death, restart
            return ("fitter", 1) in incarnations and incarnations[("fitter", 1)].state == (
                "running")

        _wait(restarted, "no restarted fitter")
        with lock:
            replay = list(captured)
        def refused_all() -> bool:
            # Sent again until all are seen: "running" may come a moment before the new
            # process's subscription reaches the intruder's side (a repeat is refused too).
            for payload in replay:
                intruder.put(intruder.key("frame"), payload, MUST_ARRIVE)
            try:
                _wait(lambda: incarnations[("fitter", 1)].ignored >= len(replay), "", 5.0)
            except AssertionError:
                return False
            return True

        _wait(refused_all, f"the restarted fitter did not see the {len(replay)} replayed "
              f"frames: {incarnations[('fitter', 1)]}")  # the positive control
        outcome = stack.wait()
    summary = stack.summary()
    assert outcome == "done" and summary["services"]["fitter"]["restarts"] == 1
    assert summary["unanswered"]["fit"] > 0, summary  # what the dead fitter missed
    assert summary["late"]["fit"] == 0  # and none of it answered late
    assert exit_code(outcome, summary) == 1
