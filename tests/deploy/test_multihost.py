"""Two hosts as network namespaces: the camera host runs the source, the compute host the
router and the other services; the fits equal those of a single-host run of the same video.

The namespaces are joined by a veth pair with addresses in 10.99.N.0/24 that exist only
inside them; both are deleted in ``finally``.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from services.stack.launcher import Stack, free_port
from services.stack.options import parse_run_args
from services.stack.recorder import load_messages
from tests.deploy.conftest import REPO_ROOT, RouterProcess, child_env

RUN_TIMEOUT = 60.0
LANDMARK_TOLERANCE_PX = 1.0
COMPUTE_SERVICES = ("detector", "fitter", "pose", "expression")


@dataclass(frozen=True)
class Hosts:
    """Two namespaces and their addresses on the link between them."""

    cam: str
    compute: str
    cam_ip: str
    compute_ip: str

    def exec_prefix(self, ns: str) -> list[str]:
        return ["ip", "netns", "exec", ns]


def _ip(*args: str) -> None:
    done = subprocess.run(["ip", *args], capture_output=True, text=True, timeout=20)
    if done.returncode != 0:
        raise RuntimeError(f"ip {' '.join(args)}: {done.stderr.strip()}")


@pytest.fixture
def hosts() -> Iterator[Hosts]:
    """Namespaces ``aamcam<pid>`` and ``aamcompute<pid>`` joined by a veth pair."""
    tag = os.getpid() % 100000
    net = 20 + os.getpid() % 200
    h = Hosts(f"aamcam{tag}", f"aamcompute{tag}", f"10.99.{net}.1", f"10.99.{net}.2")
    if shutil.which("ip") is None:
        pytest.skip("iproute2 (the ip command) is not installed: no network namespaces")
    probe = subprocess.run(["ip", "netns", "add", h.cam], capture_output=True, text=True,
                           timeout=20)
    if probe.returncode != 0:
        pytest.skip(f"cannot create network namespaces here (ip netns add: "
                    f"{probe.stderr.strip() or probe.returncode})")
    try:
        _ip("netns", "add", h.compute)
        veth_cam, veth_compute = f"aamc{tag}", f"aamk{tag}"
        _ip("link", "add", veth_cam, "type", "veth", "peer", "name", veth_compute)
        for ns, dev, ip in ((h.cam, veth_cam, h.cam_ip), (h.compute, veth_compute,
                                                          h.compute_ip)):
            _ip("link", "set", dev, "netns", ns)
            _ip("-n", ns, "addr", "add", f"{ip}/24", "dev", dev)
            _ip("-n", ns, "link", "set", dev, "up")
            _ip("-n", ns, "link", "set", "lo", "up")
        yield h
    finally:
        for ns in (h.cam, h.compute):  # deleting a namespace deletes its end of the veth
            subprocess.run(["ip", "netns", "del", ns], capture_output=True, timeout=20)


def service_cmd(hosts: Hosts, ns: str, name: str, args: list[str]) -> list[str]:
    return [*hosts.exec_prefix(ns), sys.executable, "-m", "services", "service", name, *args]


def _stop(procs: list[subprocess.Popen]) -> None:
    for p in procs:
        if p.poll() is None:
            p.terminate()
    for p in procs:
        try:
            p.wait(10)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait(5)


def multihost_fits(hosts: Hosts, video: Path, models: dict[str, list[str]],
                   rec: Path) -> dict[int, object]:
    """Run the split stack on ``video``; the fits the compute host recorded, by frame."""
    router_ep = f"tcp/{hosts.compute_ip}:7447"
    router = RouterProcess(["--listen", router_ep], REPO_ROOT,
                           prefix=hosts.exec_prefix(hosts.compute))
    compute_bus = ["--stream", "mh", "--mode", "peer", "--listen", f"tcp/{hosts.compute_ip}:0",
                   "--connect", router_ep]
    extra = {"fitter": ["--warp", "cpu", *models["fitter"]], "pose": ["--fov", "60"],
             "expression": models["expression"], "detector": []}
    procs: list[subprocess.Popen] = []
    logs = rec.with_suffix(".log").open("w")
    try:
        for name in COMPUTE_SERVICES:
            procs.append(subprocess.Popen(
                service_cmd(hosts, hosts.compute, name, compute_bus + extra[name]),
                env=child_env(), cwd=REPO_ROOT, stdout=logs, stderr=subprocess.STDOUT))
        recorder = subprocess.Popen(
            [*hosts.exec_prefix(hosts.compute), sys.executable, "-m", "services", "record",
             "--out", str(rec), "--until-eos", "--duration", str(RUN_TIMEOUT), *compute_bus],
            env=child_env(), cwd=REPO_ROOT, stdout=logs, stderr=subprocess.STDOUT)
        procs.append(recorder)
        # The camera host has no listener: a client reaches everything through the router.
        source = subprocess.Popen(
            service_cmd(hosts, hosts.cam, "source", [
                "--stream", "mh", "--mode", "client", "--connect", router_ep,
                "--video", str(video), "--pace", "fast",
                "--wait-for", ",".join((*COMPUTE_SERVICES, "record")), "--wait-timeout", "60"]),
            env=child_env(), cwd=REPO_ROOT, stdout=logs, stderr=subprocess.STDOUT)
        procs.append(source)
        recorder.wait(RUN_TIMEOUT + 10)
        assert source.wait(10) == 0, rec.with_suffix(".log").read_text()[-3000:]
    finally:
        _stop(procs)
        router.stop()
        logs.close()
    return {m.header.frame_index: m for m in load_messages(rec, ["fit"])}


def single_host_fits(video: Path, models: dict[str, list[str]],
                     rec: Path) -> dict[int, object]:
    """The same services started by the launcher on loopback; its recorded fits by frame."""
    opts = parse_run_args([
        "--video", str(video), "--pace", "fast", "--warp", "cpu", "--no-ar", "--stream", "sh",
        "--record", str(rec), "--endpoint", f"tcp/127.0.0.1:{free_port()}", "--drain-max", "10",
        *models["fitter"], "--classifier", models["expression"][-1]])
    with Stack(opts) as stack:
        assert stack.wait() == "done", stack.summary()
    return {m.header.frame_index: m for m in load_messages(rec, ["fit"])}


def test_split_across_two_hosts_gives_the_single_host_fits(
    hosts: Hosts, data_dir: Path, models: dict[str, list[str]], tmp_path: Path,
) -> None:
    video = data_dir / "videos" / "single_face.mp4"
    started = time.monotonic()
    split = multihost_fits(hosts, video, models, tmp_path / "multi.rec")
    single = single_host_fits(video, models, tmp_path / "single.rec")
    assert sorted(split) == sorted(single) == list(range(72))
    both = [i for i in single if not single[i].failed and not split[i].failed]
    assert len(both) >= 60, f"only {len(both)} frames fitted in both runs"
    assert [i for i in single if single[i].failed] == [i for i in split if split[i].failed]
    worst = max(float(np.abs(single[i].landmarks - split[i].landmarks).max()) for i in both)
    print(f"frames fitted in both runs: {len(both)}, largest landmark difference {worst:.3f} px")
    assert worst <= LANDMARK_TOLERANCE_PX, f"landmarks differ by up to {worst:.2f} px"
    assert time.monotonic() - started < 90
