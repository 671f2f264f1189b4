"""Reliability bench: Ctrl-C at random moments, and how fast bad options are refused.

Run: ``python -m bench reliability [--runs 50] [--small-model]``

1. **Ctrl-C**: ``aamtrack run`` on ``single_face.mp4`` played forever with a
   Rerun recording and a message recording, in a process group of its own;
   after a random 1-12 s, SIGINT to the whole group (as a terminal's Ctrl-C
   does). Counted per run: a hang (not gone 20 s later), the exit code, whether
   the ``.rrd`` verifies (``rerun rrd verify``) and the ``.rec`` loads whole.
   Target: 0 hangs, every ``.rrd`` verifies, every ``.rec`` loads.
2. **Option errors**: each bad option of ``aamtrack run`` (a text, truncated
   or old model, a garbage or NaN calibration, one of focal length 1e300,
   ``--fov 0``, ``--jpeg 500``, ``--loop -1``, a video over 4096 px, a busy
   endpoint, output files that cannot be written, a camera that is not there),
   with the time to its exit. Target: exit 2 with one line, within 2 s.
3. **Hostile and careless peers** (:mod:`reliability_cases`): extreme fits, a
   forged frame 0, a forged end of stream, the pose service killed, another OS
   user; each case ``--hostile-runs`` times. Target: every case passes every run.
"""

from __future__ import annotations

import json
import os
import random
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from aamcore.config import REPO_ROOT, data_root
from aamcore.expression.training import classifier_path
from bench import options
from bench.targets import Target
from services.stack.recorder import read_recording

CTRL_C = Target("Ctrl-C at random moments: 0 hangs, every .rrd written verifies, every .rec "
                "written loads, no traceback", "==", True)
BAD_OPTIONS = Target("every bad option exits 2 with one line within 2 s", "==", True)
HOSTILE = Target("every hostile case passes in every run", "==", True)
TARGETS = (CTRL_C, BAD_OPTIONS, HOSTILE)

RERUN = Path(sys.executable).with_name("rerun")
ENV = os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO_ROOT)}
KEEP = Path(tempfile.gettempdir()) / "aamtrack-reliability"
"""Where recordings that fail their check are kept for a look."""


def interrupted_run(argv: list[str], folder: Path, k: int, rng: random.Random) -> dict:
    """One run stopped by SIGINT to its process group; what it left behind."""
    rrd, rec = folder / f"run{k}.rrd", folder / f"run{k}.rec"
    proc = subprocess.Popen([sys.executable, "-m", "services", "run", *argv, "--rrd", str(rrd),
                             "--record", str(rec)], env=ENV, cwd=REPO_ROOT,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    delay = rng.uniform(1.0, 12.0)
    time.sleep(delay)
    os.killpg(proc.pid, signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=20)
        code, hung = proc.returncode, False
    except subprocess.TimeoutExpired:
        hung = True
        os.killpg(proc.pid, signal.SIGKILL)
        _, err = proc.communicate(timeout=10)
        code = proc.returncode
    # Footers checked too: the logger writes its footer as it stops (issue 43).
    check = subprocess.run([str(RERUN), "rrd", "verify", str(rrd)],
                           capture_output=True, text=True, timeout=60) if rrd.exists() else None
    verified = check is not None and check.returncode == 0
    if check is not None and not verified:
        kept = KEEP / rrd.name
        KEEP.mkdir(parents=True, exist_ok=True)
        kept.write_bytes(rrd.read_bytes())
        print(f"  {rrd.name} does not verify (kept as {kept}): {check.stderr.strip()[-300:]}")
    if "Traceback" in err:
        tail = "\n    ".join(err[err.index("Traceback"):].splitlines()[:40])
        print(f"  run {k + 1} printed a traceback:\n    {tail}")
    loads = rec.exists() and read_recording(rec).stopped == ""
    return {"delay": delay, "code": code, "hung": hung, "rrd": verified, "rec": loads,
            "rrd_made": rrd.exists(), "rec_made": rec.exists(), "traceback": "Traceback" in err,
            "said": all(f"no recording {p}" in err for p in (rrd, rec) if not p.exists())}


def interrupts(runs: int, model: Path, classifier: Path, seed: int) -> bool:
    rng = random.Random(seed)
    video = data_root() / "videos" / "single_face.mp4"
    argv = ["--video", str(video), "--loop", "0", "--model", str(model),
            "--classifier", str(classifier)]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(runs):
            rows.append(interrupted_run(argv, Path(tmp), k, rng))
            r = rows[-1]
            print(f"run {k + 1:>3}: SIGINT after {r['delay']:4.1f} s -> exit {r['code']}, "
                  f"{'HUNG, ' if r['hung'] else ''}rrd "
                  f"{'ok' if r['rrd'] else 'BAD' if r['rrd_made'] else 'MISSING'}, "
                  f"rec {'ok' if r['rec'] else 'BAD' if r['rec_made'] else 'MISSING'}",
                  flush=True)
    hangs = sum(r["hung"] for r in rows)
    bad_rrd = sum(r["rrd_made"] and not r["rrd"] for r in rows)
    bad_rec = sum(r["rec_made"] and not r["rec"] for r in rows)
    missing = sum(not (r["rrd_made"] and r["rec_made"]) for r in rows)
    unsaid = sum(not r["said"] for r in rows)
    tracebacks = sum(r["traceback"] for r in rows)
    codes = sorted({r["code"] for r in rows})
    print(f"\n{runs} runs: {hangs} hangs, {bad_rrd} .rrd that do not verify, {bad_rec} .rec that "
          f"do not load, {missing} stopped before a recording started ({unsaid} without saying "
          f"so), {tracebacks} with a traceback; exit codes {codes} (-2: killed by the SIGINT "
          "itself, which a shell reports as 130, as it does 130)")
    return CTRL_C.check(hangs == 0 and bad_rrd == 0 and bad_rec == 0 and tracebacks == 0,
                        f"{runs} runs")


def bad_inputs(folder: Path, model: Path) -> list[tuple[str, list[str]]]:
    """``(what, run arguments)`` of each bad option."""
    video = str(data_root() / "videos" / "single_face.mp4")
    text = folder / "model.npz"
    text.write_text("not a model\n")
    cut = folder / "cut.npz"
    cut.write_bytes(model.read_bytes()[:5000])
    with np.load(model, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    header = json.loads(arrays["header"].tobytes())
    header["format_version"] = 1
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), np.uint8)
    old = folder / "old.npz"
    np.savez(old, **arrays)
    garbage = folder / "cam.yaml"
    garbage.write_bytes(b"\x00\x01 not a calibration")
    nan = folder / "nan.json"
    nan.write_text('{"camera_matrix": [[800, 0, 320], [0, 800, 240], [0, 0, 1]], '
                   '"image_width": NaN, "image_height": 480}')
    wide = folder / "wide.mp4"
    writer = cv2.VideoWriter(str(wide), cv2.VideoWriter_fourcc(*"mp4v"), 10, (4200, 16))
    for _ in range(3):
        writer.write(np.zeros((16, 4200, 3), np.uint8))
    writer.release()
    huge = folder / "huge.json"
    huge.write_text('{"camera_matrix": [[1e300, 0, 320], [0, 1e300, 240], [0, 0, 1]], '
                    '"image_width": 640, "image_height": 480}')
    return [("text model", ["--video", video, "--model", str(text)]),
            ("calibration fx 1e300", ["--video", video, "--calibration", str(huge)]),
            ("--rrd /proc/x.rrd", ["--video", video, "--rrd", "/proc/x.rrd"]),
            ("--rrd into no folder", ["--video", video, "--rrd", str(folder / "no" / "x.rrd")]),
            ("--rrd a folder", ["--video", video, "--rrd", str(folder)]),
            ("--summary into no folder", ["--video", video, "--summary",
                                          str(folder / "no" / "s.json")]),
            ("--record /proc/x.rec", ["--video", video, "--record", "/proc/x.rec"]),
            ("--camera 7", ["--camera", "7"]),
            ("truncated model", ["--video", video, "--model", str(cut)]),
            ("model of format 1", ["--video", video, "--model", str(old)]),
            ("garbage calibration", ["--video", video, "--calibration", str(garbage)]),
            ("calibration width NaN", ["--video", video, "--calibration", str(nan)]),
            ("--fov 0", ["--video", video, "--fov", "0"]),
            ("--jpeg 500", ["--video", video, "--jpeg", "500"]),
            ("--loop -1", ["--video", video, "--loop", "-1"]),
            ("4200 px video", ["--video", str(wide)])]


def option_errors(model: Path) -> bool:
    ok = True
    print(f"{'bad option':<24}{'exit':>5}{'seconds':>9}  message")
    with tempfile.TemporaryDirectory() as tmp, socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        cases = bad_inputs(Path(tmp), model)
        cases.append(("busy --endpoint", ["--video", str(data_root() / "videos" /
                                                         "single_face.mp4"), "--endpoint",
                                          f"tcp/127.0.0.1:{busy.getsockname()[1]}"]))
        for what, argv in cases:
            started = time.monotonic()
            done = subprocess.run([sys.executable, "-m", "services", "run", *argv], env=ENV,
                                  cwd=REPO_ROOT, capture_output=True, text=True, timeout=60)
            took = time.monotonic() - started
            lines = [line for line in done.stderr.splitlines() if line.strip()]
            good = done.returncode == 2 and len(lines) == 1 and took <= 2.0
            ok &= good
            print(f"{what:<24}{done.returncode:>5}{took:>9.2f}  {lines[0] if lines else '?'}")
    return BAD_OPTIONS.check(ok)


def hostile(runs: int, model: Path, classifier: Path) -> bool:
    from bench.reliability_cases import CASES

    argv = ["--video", str(data_root() / "videos" / "single_face.mp4"), "--model", str(model),
            "--classifier", str(classifier), "--no-ar"]
    ok = True
    print(f"{'case':<16}{'passed':>9}  last run")
    for name, case in CASES.items():
        results = [case(argv) for _ in range(runs)]
        passed = sum(good for good, _ in results)
        ok &= passed == runs
        print(f"{name:<16}{passed:>5} of {runs}  {results[-1][1]}", flush=True)
    return HOSTILE.check(ok, f"{runs} runs each")


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__, model=True)
    parser.add_argument("--runs", type=int, default=50, help="Ctrl-C runs")
    parser.add_argument("--small-model", action="store_true",
                        help="the small test model (300 faces), as the tests use")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--hostile-runs", type=int, default=20)
    parser.add_argument("--only", choices=("options", "interrupts", "hostile"),
                        help="one section only")
    args = options.parse(parser, argv)
    model = (options.model_path(args, max_images=10, limit=300) if args.small_model
             else options.model_path(args))
    classifier = classifier_path(model)
    ok = True
    if args.only in (None, "options"):
        ok &= option_errors(model)
        print()
    if args.only in (None, "hostile"):
        ok &= hostile(args.hostile_runs, model, classifier)
        print()
    if args.only in (None, "interrupts"):
        ok &= interrupts(args.runs, model, classifier, args.seed)
    return 0 if ok else 1

