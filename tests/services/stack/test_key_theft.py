"""The run's private keys stay in the run's processes: a real run and a real thief, both
processes of one user without capabilities (``setpriv``), the thief trying every route
(``key_thief.py``): the launcher's and every service's memory and environment, the key
channel's file, the start-up race (a service paused before its first instruction, as if
the thief had won the race: ``sitecustomize.py`` below), the restart race, a debugger
attached before the service hardens, a key request of the thief's own.

Each case checks its positive control first (the thief reached the paused service: it read
its environment and duplicated its files, or attached to it), then that no key came out.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from aamcore.config import REPO_ROOT
from proto.auth import public_key
from services.stack.recorder import read_recording

THIEF = Path(__file__).with_name("key_thief.py")
SETPRIV = shutil.which("setpriv")
NO_CAPS = [SETPRIV or "setpriv", "--bounding-set=-all", "--inh-caps=-all",
           "--ambient-caps=-all", "--no-new-privs"]
SITECUSTOMIZE = '''
import os, time
cmdline = open("/proc/self/cmdline", "rb").read().split(b"\\0")
paused = os.environ.get("AAMTRACK_TEST_PAUSE", "").encode()
if b"services.stack.child" in cmdline and paused and paused in b" ".join(cmdline):
    folder = os.environ["AAMTRACK_TEST_PAUSE_DIR"]
    open(f"{folder}/waiting-{os.getpid()}", "w").close()
    deadline = time.monotonic() + 300
    while not os.path.exists(f"{folder}/go-{os.getpid()}") and time.monotonic() < deadline:
        time.sleep(0.01)
'''

pytestmark = pytest.mark.skipif(SETPRIV is None or os.geteuid() != 0,
                                reason="needs setpriv, and root to drop every capability")


def _theft(tmp_path: Path, models: tuple[Path, Path], video: Path, thief_args: list[str],
           run_args: list[str], kill_fitter: bool = False) -> tuple[int, list[str], dict]:
    """A run with the fitter paused at each start and the thief beside it: the run's exit
    code, its standard error lines and the thief's report."""
    folder = tmp_path / "pause"
    folder.mkdir()
    (folder / "sitecustomize.py").write_text(SITECUSTOMIZE)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(folder), str(REPO_ROOT)]),
           "AAMTRACK_TEST_PAUSE": "services.fitter.service",
           "AAMTRACK_TEST_PAUSE_DIR": str(folder), "XDG_RUNTIME_DIR": str(tmp_path)}
    run = subprocess.Popen([*NO_CAPS, sys.executable, "-m", "services", "run", "--video",
                            str(video), "--no-ar", "--pace", "fast", "--model",
                            str(models[0]), "--classifier", str(models[1]), *run_args],
                           env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                           text=True)
    thief = subprocess.Popen([*NO_CAPS, sys.executable, str(THIEF), str(folder),
                              str(tmp_path / "thief.json"), str(run.pid), *thief_args])
    try:
        if kill_fitter:  # the restart race: once let go, the fitter dies and comes back
            deadline = time.monotonic() + 300
            while not list(folder.glob("go-*")) and time.monotonic() < deadline:
                time.sleep(0.05)
            os.kill(int(next(folder.glob("go-*")).name.split("-")[1]), signal.SIGKILL)
        _, err = run.communicate(timeout=600)
    finally:
        (folder / "stop").write_text("")
        thief.wait(timeout=60)
        if run.poll() is None:
            run.kill()
    lines = [x for x in err.splitlines() if " INFO " not in x and " WARNING " not in x
             and not x.startswith("aamtrack: ")]
    return run.returncode, lines, json.loads((tmp_path / "thief.json").read_text())


@pytest.fixture
def models(model_path: Path, classifier_path: Path) -> tuple[Path, Path]:
    return model_path, classifier_path


def _stolen(report: dict, public: set[bytes]) -> list[str]:
    """The thief's candidates that are private keys of the run."""
    return [c for c in report["candidates"] if public_key(bytes.fromhex(c)) in public]


def _refused(report: dict, *routes: str) -> None:
    for route in routes:
        counts = report["routes"].get(route, {"opened": 0, "refused": 0})
        assert counts["opened"] == 0 and counts["refused"] > 0, (route, report["routes"])


def test_a_service_traced_before_it_hardens_is_refused_its_key_and_the_run_stops(
    tmp_path: Path, single_face: Path, models: tuple[Path, Path],
) -> None:
    code, lines, report = _theft(tmp_path, models, single_face, ["--trace"], [])
    assert report["seized"], report  # the positive control: the thief did attach to it
    assert code == 2, lines
    error = [x for x in lines if x.startswith("aamtrack run: error")]
    assert len(error) == 1 and "fitter" in error[0] and "traced" in error[0], lines
    assert report["peeked"] == [], report  # nothing ever came through its channel
    _refused(report, "launcher memory once hardened", "launcher environ once hardened")


def test_a_key_request_of_another_process_is_refused_and_the_run_stops(
    tmp_path: Path, single_face: Path, models: tuple[Path, Path],
) -> None:
    code, lines, report = _theft(tmp_path, models, single_face, ["--forge"], [])
    assert report["routes"]["forged key request"]["opened"] >= 1, report  # it got one in
    assert code == 2, lines
    error = [x for x in lines if x.startswith("aamtrack run: error")]
    assert len(error) == 1 and "made by pid" in error[0], lines
    assert set(report["peeked"]) <= {"refused"}, report  # what came back to it
    _refused(report, "launcher memory once hardened", "launcher environ once hardened")


def test_no_route_gives_a_key_at_start_at_a_restart_or_while_the_run_lasts(
    tmp_path: Path, single_face: Path, models: tuple[Path, Path],
) -> None:
    rec = tmp_path / "run.rec"
    code, lines, report = _theft(tmp_path, models, single_face, [],
                                 ["--record", str(rec), "--summary", str(tmp_path / "s.json")],
                                 kill_fitter=True)
    assert code in (0, 1), lines  # 1 when frames were lost to the killed fitter
    assert len(report["caught"]) == 2 and report["dups"] >= 2, report  # start and restart
    keys = read_recording(rec).run_keys
    assert keys is not None and len(keys.keyring.public) >= 5
    assert _stolen(report, set(keys.keyring.public.values())) == []
    _refused(report, "launcher memory once hardened", "launcher environ once hardened",
             "service memory once hardened",
             "service environ once hardened")
    assert report["peeked"] == [], report
    summary = json.loads((tmp_path / "s.json").read_text())
    assert summary["services"]["fitter"]["restarts"] == 1 and not summary["insecure"]
