"""Deployment bench: a stack file over two hosts through ``aamtrack router``, in each mode
``deploy/`` documents, on a long real clip.

Run (root, for the network namespaces): ``OMP_NUM_THREADS=1 .venv/bin/python
bench/bench_deploy.py [--frames 472] [--modes peer client] [--runs 1]``

The two hosts are network namespaces joined by a veth pair; the compute host runs the
router and ``detector``, ``fitter``, ``pose``, ``expression``, the camera host the source,
each with ``aamtrack run --stack FILE --host NAME`` as the README says, with a keys file
made by ``aamtrack keys``. The clip is ``single_face.mp4`` played forwards, backwards and
forwards again until it has ``--frames`` frames (a real face that never cuts: the data
holds no longer clip of one person). For each mode the table gives the frames of the end
of stream, those with a fit and with a pose on each host, both exit codes and the wall
time. Target (issue 37): every frame posed in every mode, both launchers exit 0.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2

from aamcore.config import REPO_ROOT, data_root
from bench import options
from bench.targets import Target

ENV = os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO_ROOT)}
COMPUTE = ("detector", "fitter", "pose", "expression")
EVERY_FRAME = Target("every frame of the clip posed on both hosts in every mode, both "
                     "launchers exit 0", "==", True)
TARGETS = (EVERY_FRAME,)


def ping_pong_clip(path: Path, frames: int) -> Path:
    """``single_face.mp4`` forwards, backwards, forwards... to ``frames`` frames."""
    cap = cv2.VideoCapture(str(data_root() / "videos" / "single_face.mp4"))
    images = []
    while (got := cap.read())[0]:
        images.append(got[1])
    fps = cap.get(cv2.CAP_PROP_FPS) or 30.0
    cap.release()
    order, k, step = [], 0, 1
    while len(order) < frames:
        order.append(k)
        if not 0 <= k + step < len(images):
            step = -step
        k += step
    h, w = images[0].shape[:2]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, (w, h))
    for i in order:
        writer.write(images[i])
    writer.release()
    return path


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, timeout=20)


class Namespaces:
    """Two network namespaces joined by a veth pair (deleted on exit)."""

    def __init__(self) -> None:
        tag = os.getpid() % 100000
        self.cam, self.compute = f"bdcam{tag}", f"bdcomp{tag}"
        net = 10 + os.getpid() % 200
        self.cam_ip, self.compute_ip = f"10.98.{net}.1", f"10.98.{net}.2"

    def __enter__(self) -> Namespaces:
        _ip("netns", "add", self.cam)
        _ip("netns", "add", self.compute)
        a, b = f"bdc{os.getpid() % 100000}", f"bdk{os.getpid() % 100000}"
        _ip("link", "add", a, "type", "veth", "peer", "name", b)
        for ns, dev, ip in ((self.cam, a, self.cam_ip), (self.compute, b, self.compute_ip)):
            _ip("link", "set", dev, "netns", ns)
            _ip("-n", ns, "addr", "add", f"{ip}/24", "dev", dev)
            _ip("-n", ns, "link", "set", dev, "up")
            _ip("-n", ns, "link", "set", "lo", "up")
        return self

    def __exit__(self, *exc: object) -> None:
        for ns in (self.cam, self.compute):
            subprocess.run(["ip", "netns", "del", ns], capture_output=True, timeout=20)

    def cmd(self, ns: str, *args: str) -> list[str]:
        return ["ip", "netns", "exec", ns, sys.executable, "-m", "services", *args]


def stack_file(folder: Path, ns: Namespaces, mode: str) -> Path:
    path = folder / f"{mode}.toml"
    path.write_text(f"""[bus]
stream = "bench"
router = "tcp/{ns.compute_ip}:7447"
keys = "run.keys"

[hosts.camera]
address = "{ns.cam_ip}"
mode = "{mode}"
services = ["source"]

[hosts.compute]
address = "{ns.compute_ip}"
mode = "{mode}"
router = true
services = {json.dumps(list(COMPUTE))}

[services.source]
pace = "fast"

[services.fitter]
warp = "cpu"
""")
    return path


def run_mode(ns: Namespaces, folder: Path, mode: str, clip: Path) -> dict:
    stack = stack_file(folder, ns, mode)
    router = subprocess.Popen(ns.cmd(ns.compute, "router", "--listen",
                                     f"tcp/{ns.compute_ip}:7447"),
                              env=ENV, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                              text=True)
    assert router.stdout is not None and "listening" in router.stdout.readline()
    started = time.monotonic()
    try:
        procs = {host: subprocess.Popen(
            ns.cmd(ns.compute if host == "compute" else ns.cam, "run", "--stack", str(stack),
                   "--host", host, "--summary", str(folder / f"{mode}.{host}.json"),
                   *(["--video", str(clip)] if host == "camera" else [])),
            env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            for host in ("compute", "camera")}
        codes = {host: p.wait(1800) for host, p in procs.items()}
        errors = {host: p.stderr.read()[-400:] for host, p in procs.items() if p.stderr}
    finally:
        router.terminate()
        router.wait(20)
    row: dict = {"mode": mode, "codes": codes, "wall": time.monotonic() - started}
    for host in ("camera", "compute"):
        path = folder / f"{mode}.{host}.json"
        summary = json.loads(path.read_text()) if path.exists() else {}
        row[host] = (summary.get("total_frames"), summary.get("frames_with", {}).get("fit"),
                     summary.get("frames_with", {}).get("pose"))
        if codes[host] != 0:
            print(f"  {mode} {host} exit {codes[host]}: {errors.get(host, '')}")
    return row


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__)
    parser.add_argument("--frames", type=int, default=472)
    parser.add_argument("--modes", nargs="+", default=["peer", "client"])
    parser.add_argument("--runs", type=int, default=1)
    args = options.parse(parser, argv)
    ok = True
    with tempfile.TemporaryDirectory() as tmp, Namespaces() as ns:
        folder = Path(tmp)
        clip = ping_pong_clip(folder / "clip.mp4", args.frames)
        subprocess.run([sys.executable, "-m", "services", "keys", str(folder / "run.keys")],
                       env=ENV, check=True, capture_output=True)
        print(f"clip: single_face.mp4 forwards and backwards, {args.frames} frames; load "
              f"{os.getloadavg()[0]:.1f}")
        print(f"{'mode':<8}{'run':>4}  {'camera: eos/fit/pose':<22}{'compute: eos/fit/pose':<23}"
              f"{'exit':<12}{'wall s':>7}")
        for mode in args.modes:
            for k in range(args.runs):
                row = run_mode(ns, folder, mode, clip)
                good = (all(c == 0 for c in row["codes"].values()) and all(
                    row[h] == (args.frames,) * 3 for h in ("camera", "compute")))
                ok &= good
                print(f"{mode:<8}{k + 1:>4}  {'/'.join(map(str, row['camera'])):<22}"
                      f"{'/'.join(map(str, row['compute'])):<23}"
                      f"{','.join(str(c) for c in row['codes'].values()):<12}"
                      f"{row['wall']:>7.1f}", flush=True)
    return 0 if EVERY_FRAME.check(ok) else 1

