"""End to end: the whole stack as real processes on a loopback Zenoh bus, on real videos.

Each test starts every service with the spawn method (detector, fitter, pose,
expression, optionally the glasses renderer and the Rerun logger, then the
source), runs a video through, and checks what came out of the recording the
launcher keeps and the services' last statuses.
"""

from __future__ import annotations

import logging
import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import msgpack
import numpy as np
import pytest

from aamcore.config import REPO_ROOT
from aamcore.fitting.search import SearchSchedule
from proto import Fit, Frame, Header, encode
from proto.auth import Keyring
from services.bus.connection import BusOptions
from services.bus.qos import MUST_ARRIVE
from services.bus.session import Service
from services.bus.shm import POOL_IMAGES
from services.stack.launcher import Stack, free_port
from services.stack.options import StackOptions
from services.stack.outcome import EXIT_FAILED, exit_code, unanswered_problem
from services.stack.preflight import prepare_models
from services.stack.recorder import load_messages, read_recording
from tests.expectations import FRAMES, GOOD_SHARE, check_poses, pose_angles
from tests.videos import decoded_frames

RERUN_CLI = Path(sys.executable).with_name("rerun")


def run_stack(opts: StackOptions) -> tuple[Stack, dict]:
    with Stack(opts) as stack:
        outcome = stack.wait()
    assert outcome == "done", stack.summary()
    return stack, stack.summary()


def by_frame(messages: list, kind: str) -> dict[int, object]:
    return {m.header.frame_index: m for m in messages if kind == m.KIND}


def assert_accounted(summary: dict, service: str = "fitter") -> None:
    """Every frame published was taken by ``service`` or counted as dropped, and every frame
    it took was answered with one message."""
    s = summary["services"][service]
    assert s["frames_in"] + s["dropped"] == summary["total_frames"], s
    assert s["lost"] == 0 and summary["frames_lost"] == 0, s
    assert s["failed"] == 0 and s["frames_out"] == s["frames_in"], s


def rrd_entities(path: Path) -> set[str]:
    from rerun.chunk import RrdReader

    return {chunk.entity_path for chunk in RrdReader(path).stream()}


def intruder_bus(stack: Stack) -> BusOptions:
    return BusOptions(stack.opts.launch.stream, listen=("tcp/127.0.0.1:0",),
                      connect=(stack.endpoint,))


def wait_for(condition: Callable[[], bool], what: str, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, what
        time.sleep(0.05)


def test_single_face_gpu_warp_every_frame_gets_its_results(
    single_face: Path, tmp_path: Path, stack_options: Callable[..., StackOptions],
    classifier_path: Path,
) -> None:
    rrd, rec = tmp_path / "run.rrd", tmp_path / "run.rec"
    # the default method samples its appearance on the CPU; one fixed-Jacobian iteration of
    # refinement per good fit is what warps on the GPU worker
    opts = stack_options(single_face, warp="gpu", refine=1, record=str(rec), rrd=str(rrd))
    stack, summary = run_stack(opts)
    assert summary["total_frames"] == 72 and summary["eos_reason"] == "end_of_file"
    messages = load_messages(rec)
    fits = by_frame(messages, "fit")
    assert sorted(fits) == list(range(72))
    # Every good fit has its appearance, refined through the GPU worker; a failed fit of
    # the default method (a landmark regressor's) has none and warped nothing.
    assert {f.warp_path for f in fits.values() if f.appearance is not None} == {"gpu"}
    assert all(f.appearance is not None for f in fits.values() if not f.failed)
    assert {f.warp_path for f in fits.values() if f.appearance is None} <= {"none"}
    assert {f.header.run_id for f in fits.values()} == {stack.run_id}
    reasons = sorted({f.failure_reason for f in fits.values() if f.failed})
    assert sum(not f.failed for f in fits.values()) >= GOOD_SHARE * FRAMES, reasons
    poses = by_frame(messages, "pose")
    assert sorted(poses) == list(range(72))
    good = [k for k in range(72) if not fits[k].failed]
    check_poses([poses[k].reliable for k in good], [poses[k].reason for k in good],
                pose_angles(poses))
    # Every fit gets its expression: a label from the first good frames on (the
    # person-independent model decides while the reference is made), else the reason.
    expressions = by_frame(messages, "expression")
    assert sorted(expressions) == list(range(72))
    expressed = sorted(k for k, e in expressions.items() if e.label)
    assert all(e.reason for e in expressions.values() if not e.label)
    assert expressed and min(expressed) - good[0] <= 2
    assert len(expressed) >= GOOD_SHARE * len(good)
    assert summary["frames_with"]["expression"] == len(expressed)
    assert summary["messages"]["overlay"] > 0
    assert summary["services"]["ar"]["frames_out"] == summary["messages"]["overlay"]
    assert all(code == 0 for code in stack.exit_codes.values()), stack.exit_codes
    for name, s in summary["services"].items():
        assert s["state"] == "stopped" and s["rejected"] == 0 and s["lost"] == 0, (name, s)
    assert summary["services"]["fitter"]["dropped"] == 0  # fast pacing waits for each fit
    done = subprocess.run([str(RERUN_CLI), "rrd", "verify", str(rrd)], capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 0, done.stdout + done.stderr
    entities = rrd_entities(rrd)
    for entity in ("/world/camera/video", "/world/camera/landmarks", "/world/head", "/overlay"):
        assert entity in entities, sorted(entities)


def test_single_face_cpu_warp_with_jpeg_frames(
    single_face: Path, tmp_path: Path, stack_options: Callable[..., StackOptions],
    classifier_path: Path,
) -> None:
    rec = tmp_path / "run.rec"
    _, summary = run_stack(stack_options(single_face, warp="cpu", jpeg=90, ar=False,
                                         record=str(rec)))
    fits = by_frame(load_messages(rec, ["fit"]), "fit")
    assert sorted(fits) == list(range(72))
    assert {f.warp_path for f in fits.values() if not f.failed} == {"cpu"}
    assert summary["frames_with"]["pose"] == 72
    assert summary["messages"]["expression"] == 72  # every fit answered, a label or why not
    assert summary["frames_with"]["expression"] >= GOOD_SHARE * FRAMES
    assert_accounted(summary)


def test_no_face_video_every_frame_is_answered_as_no_face(
    no_face: Path, tmp_path: Path, stack_options: Callable[..., StackOptions],
) -> None:
    rec = tmp_path / "run.rec"
    stack, summary = run_stack(stack_options(no_face, ar=False, record=str(rec)))
    total = decoded_frames(no_face)
    assert summary["total_frames"] == total > 90
    fits = by_frame(load_messages(rec, ["fit"]), "fit")
    assert sorted(fits) == list(range(total))
    assert all(f.failed and f.failure_reason == "no face" and len(f.landmarks) == 0
               for f in fits.values())
    assert summary["frames_with"]["pose"] == 0 and summary["frames_with"]["expression"] == 0
    assert f"{total} fits without expression: {total} no face" in (
        summary["services"]["expression"]["message"])
    # Searched on the frames the search schedule picks, each pass a query (or, when the
    # detector did not answer in time, a local detection).
    passes = sum(sum(SearchSchedule().passes(k)) for k in range(total))
    found = re.search(r"(\d+) detector queries, (\d+) local detections",
                      summary["services"]["fitter"]["message"])
    assert found is not None and int(found[1]) + int(found[2]) == passes < 2 * total
    assert all(code == 0 for code in stack.exit_codes.values()), stack.exit_codes


@pytest.mark.parametrize("kind", ["missing", "corrupt"])
def test_bad_video_file_exits_2_with_a_message(
    kind: str, tmp_path: Path, run_cli: Callable[..., subprocess.CompletedProcess[str]]
) -> None:
    video = tmp_path / "clip.mp4"
    if kind == "corrupt":
        video.write_bytes(b"this is not a video\n" * 100)
    done = run_cli("run", "--video", str(video), timeout=60)
    assert done.returncode == 2
    expected = "no such file" if kind == "missing" else "OpenCV cannot open it"
    assert expected in done.stderr, done.stdout + done.stderr


def test_a_stream_url_that_does_not_answer_stops_the_run_with_exit_1(
    run_cli: Callable[..., subprocess.CompletedProcess[str]], model_path: Path,
    classifier_path: Path,
) -> None:
    url = f"rtsp://127.0.0.1:{free_port()}/nothing"
    done = run_cli("run", "--url", url, "--no-ar", "--model", str(model_path), "--classifier",
                   str(classifier_path), "--endpoint", f"tcp/127.0.0.1:{free_port()}",
                   timeout=120)
    assert done.returncode == 1
    assert f"aamtrack run: error: stream {url}: OpenCV cannot open it" in done.stderr


def _old_version(payload: bytes) -> bytes:
    obj = msgpack.unpackb(payload, raw=False)
    obj["header"]["schema_version"] = 1
    return msgpack.packb(obj, use_bin_type=True)


INVALID = 10_000
FOREIGN = 1_500


def flood(intruder: Service, run_id: str) -> None:
    """Invalid messages and valid ones from outside the run on the stack's keys: garbage,
    oversized, old-schema, and real-looking frames and fits of another run, another size,
    frame 0, or a producer that does not own the key."""
    frame_key, fit_key = intruder.key("frame"), intruder.key("fit")
    image = np.zeros((24, 32, 3), np.uint8)
    fit = Fit(Header.now(intruder.stream, 3, "fitter", run_id="run-other"), "ibug68",
              np.zeros((68, 2), np.float32) + 100, np.array([1.0, 0.0, 0.0, 0.0], np.float32),
              32, 24, False, "", 0.5, "none", None)
    for k in range(INVALID // 2):
        intruder.put(frame_key, b"\x93not a message" + k.to_bytes(4, "little"), MUST_ARRIVE)
        intruder.put(fit_key, b"\xc1" * (2 << 20) if k < 10 else b"\xc1", MUST_ARRIVE)
    intruder.put(fit_key, _old_version(encode(fit)), MUST_ARRIVE)
    for k in range(FOREIGN // 3):
        index = 0 if k % 2 else k
        other_run = Header.now(intruder.stream, index, "source", run_id="run-other")
        intruder.put(frame_key, encode(Frame.from_array(other_run, image)), MUST_ARRIVE)
        wrong_owner = Header.now(intruder.stream, k, "intruder")
        intruder.put(frame_key, encode(Frame.from_array(wrong_owner, image)), MUST_ARRIVE)
    for k in range(FOREIGN // 3):  # as the run's own source, unsigned: frame 0, far ahead
        forged = Header.now(intruder.stream, 0 if k % 2 else 900_000 + k, "source",
                            run_id=run_id)
        intruder.put(frame_key, encode(Frame.from_array(forged, image)), MUST_ARRIVE)


def test_a_flood_of_invalid_and_foreign_messages_displaces_no_real_frame(
    single_face: Path, stack_options: Callable[..., StackOptions],
    caplog: pytest.LogCaptureFixture, tmp_path: Path,
) -> None:
    rec = tmp_path / "flood.rec"
    opts = stack_options(single_face, ar=False, loop=2, jpeg=80, record=str(rec),
                         record_images=True)
    with Stack(opts) as stack, Service("intruder", intruder_bus(stack),
                                       handle_signals=False) as intruder:
        wait_for(lambda: stack.monitor.counts["fit"] >= 10, "the stack produced no fits")
        with caplog.at_level(logging.WARNING):
            flood(intruder, stack.run_id)
        assert stack.wait() == "done"
    summary = stack.summary()
    total, fitter = summary["total_frames"], summary["services"]["fitter"]
    assert total == 144
    assert summary["frames_with"]["fit"] == total  # no real frame displaced or lost
    assert fitter["dropped"] == 0 and fitter["lost"] == 0, fitter
    assert fitter["rejected"] == INVALID // 2 and fitter["ignored"] == FOREIGN, fitter
    # The expression service takes the frames too: it rejects the invalid frames as well.
    for name, invalid in (("pose", INVALID // 2 + 1), ("expression", INVALID + 1)):
        s = summary["services"][name]
        assert s["rejected"] == invalid and s["dropped"] == 0, (name, s)
        assert s["frames_in"] == total, (name, s)
    assert all(code == 0 for code in stack.exit_codes.values()), stack.exit_codes
    recording = read_recording(rec)  # images are screened before they are recorded
    assert recording.stopped == ""
    assert sorted(by_frame(recording.messages, "frame")) == list(range(total))


def test_killing_a_service_leaves_the_others_running_and_it_comes_back(
    single_face: Path, stack_options: Callable[..., StackOptions]
) -> None:
    opts = stack_options(single_face, ar=False, pace="realtime", loop=3)
    with Stack(opts) as stack:
        wait_for(lambda: stack.monitor.counts["pose"] >= 5, "the stack produced no poses")
        pid = stack.supervisor.pid("pose")
        assert pid is not None
        os.kill(pid, signal.SIGKILL)
        killed_at = len(stack.monitor.indices["fit"])
        assert stack.wait() == "done"
    summary = stack.summary()
    assert any("pose died" in e for e in summary["events"]), summary["events"]
    assert summary["services"]["pose"]["restarts"] == 1
    poses = stack.monitor.indices["pose"]
    assert poses.highest > killed_at + 30, "no poses after the restart"
    assert_accounted(summary)
    # The fits that came while no pose service ran got no pose: the run says so and fails.
    assert summary["unanswered"]["pose"] > 0 and summary["unanswered"]["fit"] == 0
    assert "fits with a face got no pose" in unanswered_problem(summary)
    assert "pose restarted 1 times" in unanswered_problem(summary)
    assert exit_code("done", summary) == EXIT_FAILED
    for name in ("detector", "fitter", "expression", "source"):
        assert summary["services"][name]["restarts"] == 0


def test_every_rrd_part_verifies_after_a_killed_logger_and_a_stop(
    single_face: Path, stack_options: Callable[..., StackOptions], tmp_path: Path
) -> None:
    rrd = tmp_path / "run.rrd"
    opts = stack_options(single_face, ar=False, pace="realtime", loop=0, rrd=str(rrd))
    with Stack(opts) as stack:
        wait_for(lambda: stack.monitor.counts["pose"] >= 5, "the stack produced no poses")
        pid = stack.supervisor.pid("rerun")
        assert pid is not None
        os.kill(pid, signal.SIGKILL)

        def restarted() -> bool:
            stack.supervisor.check()  # what the launcher's watch does: restarts the logger
            return ("rerun", 1) in stack.monitor.incarnations

        wait_for(restarted, "no restarted logger")
        wait_for(lambda: stack.monitor.incarnations[("rerun", 1)].frames_in >= 20,
                 "the restarted logger logged nothing")
        stack.service.request_stop("as a Ctrl-C does")
        assert stack.wait() == "stopped"
    # The killed logger's part was finished by the launcher, the restarted logger's closed
    # with its footer at the stop: both pass Rerun's checks with their default flags.
    part = tmp_path / "run.part1.rrd"
    finished = f"{rrd}: its logger did not close it; finished with its footer"
    assert finished in stack.supervisor.events
    for path in (rrd, part):
        done = subprocess.run([str(RERUN_CLI), "rrd", "verify", str(path)],
                              capture_output=True, text=True, timeout=60)
        assert done.returncode == 0, done.stdout + done.stderr
    assert "/world/camera/landmarks" in rrd_entities(part)
    assert not list(tmp_path.glob("*.backup.rrd"))


def _children(pid: int) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(stat[1]) == pid:
                found.append(int(entry.name))
    return found


def _shm_segments(pids: list[int]) -> set[Path]:
    """The Zenoh shared-memory segments (``/dev/shm/*.zenoh``) these processes hold open."""
    found = set()
    for pid in pids:
        try:
            fds = list(Path(f"/proc/{pid}/fd").iterdir())
        except OSError:
            continue
        for fd in fds:
            try:
                target = Path(os.readlink(fd))
            except OSError:
                continue
            if target.parent == Path("/dev/shm") and target.suffix == ".zenoh":
                found.add(target)
    return found


def _running(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def test_services_die_with_a_killed_launcher_and_the_next_run_is_clean(
    single_face: Path, model_path: Path, classifier_path: Path, tmp_path: Path,
    stack_options: Callable[..., StackOptions],
) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    env = os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO_ROOT)}
    log = tmp_path / "launcher.log"
    with log.open("wb") as err:
        launcher = subprocess.Popen(
            [sys.executable, "-m", "services", "run", "--video", str(single_face), "--loop",
             "0", "--no-ar", "--model", str(model_path), "--classifier", str(classifier_path),
             "--endpoint", endpoint], env=env, cwd=REPO_ROOT,
            stdout=subprocess.DEVNULL, stderr=err)
    try:
        # A program joins a running stack: it connects once the launcher listens, so that it
        # never holds the launcher's port itself (a connect to a port nobody listens on can
        # be given that port as its own).
        wait_for(lambda: "stack bus at" in log.read_text() or launcher.poll() is not None,
                 "the launcher did not start", timeout=120)
        assert launcher.poll() is None, log.read_text()[-4000:]
        probe_bus = BusOptions("cam0", listen=("tcp/127.0.0.1:0",), connect=(endpoint,))
        with Service("probe", probe_bus, handle_signals=False) as probe:
            fits = probe.inbox("fit", capacity=4)
            got = fits.get(120)
            assert got is not None, f"the stack produced no fits:\n{log.read_text()[-4000:]}"
        children = _children(launcher.pid)
        assert len(children) >= 5, children  # the services (and multiprocessing's tracker)
        segments = _shm_segments([launcher.pid, *children])
        assert any(p.stat().st_size >= POOL_IMAGES * 640 * 360 * 3 for p in segments), segments
        launcher.send_signal(signal.SIGKILL)
        launcher.wait(10)
        wait_for(lambda: not any(_running(pid) for pid in children),
                 "services outlived the launcher", timeout=60)
    finally:
        if launcher.poll() is None:
            launcher.kill()
    rec = tmp_path / "next.rec"
    _, summary = run_stack(stack_options(single_face, ar=False, record=str(rec),
                                         endpoint=endpoint))
    fits = [m.header.frame_index for m in load_messages(rec, ["fit"])]
    poses = [m.header.frame_index for m in load_messages(rec, ["pose"])]
    assert sorted(fits) == list(range(72)) and sorted(poses) == list(range(72))
    assert summary["foreign_runs"] == {}
    # No shared-memory segment of the killed run is left: each went with its process or was
    # cleaned when the next run made its own (Zenoh removes the segments no process holds).
    held = _shm_segments([int(e.name) for e in Path("/proc").iterdir() if e.name.isdigit()])
    assert not [p for p in segments if p.exists() and p not in held]


def test_without_jaffe_the_expression_service_is_started_without_a_classifier(
    single_face: Path, model_path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    caplog: pytest.LogCaptureFixture, stack_options: Callable[..., StackOptions],
) -> None:
    opts = stack_options(single_face, classifier=None)
    monkeypatch.setenv("AAMTRACK_DATA", str(tmp_path / "no-data"))
    monkeypatch.setenv("AAMTRACK_CACHE", str(tmp_path / "cache"))
    with caplog.at_level(logging.WARNING):
        ready = prepare_models(opts)
    expression = ready.services["expression"]
    assert expression.fitting_model == str(model_path)
    assert expression.expression.classifier is None
    assert any("no expression classifier" in r.getMessage() for r in caplog.records)


def test_services_of_another_run_on_the_endpoint_are_ignored_not_a_reason_to_stop(
    single_face: Path, stack_options: Callable[..., StackOptions],
) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    stray = BusOptions("cam0", listen=("tcp/127.0.0.1:0",), connect=(endpoint,),
                       run_id="run-stray")
    # A pose service of another run, with keys of its own, there before the run starts: its
    # token, statuses and poses change nothing (the source waits for the run's own pose).
    opts = stack_options(single_face, ar=False, endpoint=endpoint)
    with Service("pose", stray, status_period=0.1, handle_signals=False,
                 keyring=Keyring.generate(["pose"]).for_service("pose")) as other:
        other.ready()
        with Stack(opts) as stack:
            outcome = stack.wait()
    summary = stack.summary()
    assert outcome == "done" and exit_code(outcome, summary) == 0, summary
    assert summary["frames_with"]["pose"] == summary["total_frames"] == 72
    assert summary["foreign_runs"] == {"run-stray": ["pose"]}
    assert summary["ignored"]["another run"] >= 1


def test_frames_lost_to_a_stopped_consumer_are_counted_and_fail_the_run(
    single_face: Path, stack_options: Callable[..., StackOptions],
) -> None:
    opts = stack_options(single_face, ar=False, pace="realtime", loop=4)
    with Stack(opts) as stack:
        wait_for(lambda: stack.monitor.counts["fit"] >= 10, "the stack produced no fits")
        pid = stack.supervisor.pid("fitter")
        assert pid is not None
        published = stack.monitor.statuses["source"].frames_out
        os.kill(pid, signal.SIGSTOP)
        # 3 s of video go out while the fitter is stopped (however long a loaded machine
        # takes to publish them), more than its inbox holds.
        wait_for(lambda: stack.monitor.statuses["source"].frames_out >= published + 90,
                 "the source published nothing while the fitter was stopped", timeout=120)
        os.kill(pid, signal.SIGCONT)
        assert stack.wait() == "done"
    summary = stack.summary()
    fitter = summary["services"]["fitter"]
    total = summary["total_frames"]
    # Every frame is accounted for: answered, dropped by design, or lost on the way.
    assert fitter["frames_in"] + fitter["dropped"] + summary["frames_lost"] >= total, fitter
    assert fitter["dropped"] + summary["frames_lost"] > 0, fitter
    # A run with frames lost to a fault fails; one that only dropped frames by design does not.
    owed = summary["unanswered"]["fit"] + summary["unanswered"]["pose"]
    assert (exit_code("done", summary) == EXIT_FAILED) == (owed > 0)


def test_ctrl_c_before_the_stack_starts_names_the_recordings_never_started(
    tmp_path: Path, single_face: Path, monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    import services.stack.launcher as launcher
    from services.stack.options import parse_run_args

    def interrupted(opts: StackOptions) -> StackOptions:
        raise KeyboardInterrupt  # where a Ctrl-C during the checks of the options lands

    monkeypatch.setattr(launcher, "prepared", interrupted)
    rec, rrd = tmp_path / "run.rec", tmp_path / "run.rrd"
    opts = parse_run_args(["--video", str(single_face), "--record", str(rec), "--rrd", str(rrd)])
    with pytest.raises(KeyboardInterrupt):
        launcher.run_stack(opts)
    err = capsys.readouterr().err
    for path in (rec, rrd):
        assert f"no recording {path}: stopped before it was started" in err
