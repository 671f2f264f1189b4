"""Two hosts as network namespaces, run as the README says: ``aamtrack run --stack FILE --host
NAME`` on each, through ``aamtrack router`` on the compute host, in each mode ``deploy/``
documents (peer: the hosts' services connect directly once the router introduced them;
client: everything through the router), with the deployment's keys file: every frame of a
real clip gets its fit and its pose, both launchers exit 0. A host that never joins is
named within the start timeout.

The namespaces are joined by a veth pair with addresses in 10.99.N.0/24 that exist only
inside them; both are deleted in ``finally``.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from proto.auth import Keyring
from services.bus.trust import write_keys_file
from services.stack.launcher import NAME
from services.stack.registry import SERVICES
from tests.deploy.conftest import REPO_ROOT, RouterProcess, child_env

RUN_TIMEOUT = 180.0
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


def stack_file(folder: Path, hosts: Hosts, mode: str, models: dict[str, list[str]]) -> Path:
    """A stack file of the two hosts in ``mode``, with a keys file beside it."""
    write_keys_file(folder / "run.keys", Keyring.generate([*SERVICES, NAME]))
    model, classifier = models["expression"][1], models["expression"][3]
    path = folder / f"{mode}.toml"
    path.write_text(f"""
[bus]
stream = "mh"
router = "tcp/{hosts.compute_ip}:7447"
keys = "run.keys"

[hosts.camera]
address = "{hosts.cam_ip}"
mode = "{mode}"
services = ["source"]

[hosts.compute]
address = "{hosts.compute_ip}"
mode = "{mode}"
router = true
services = {json.dumps(list(COMPUTE_SERVICES))}

[services.source]
pace = "fast"

[services.fitter]
warp = "cpu"
model = "{model}"

[services.expression]
model = "{model}"
classifier = "{classifier}"
""")
    return path


def run_host(hosts: Hosts, ns: str, stack: Path, host: str, *args: str) -> subprocess.Popen:
    """``aamtrack run --stack FILE --host HOST`` in namespace ``ns``, as the README says."""
    return subprocess.Popen(
        [*hosts.exec_prefix(ns), sys.executable, "-m", "services", "run", "--stack", str(stack),
         "--host", host, "--summary", str(stack.with_suffix(f".{host}.json")), *args],
        env=child_env(), cwd=REPO_ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
        text=True)


def _finish(proc: subprocess.Popen, timeout: float) -> tuple[int, str]:
    try:
        out, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.terminate()
        out, _ = proc.communicate(timeout=30)
        return -1, out
    return proc.returncode, out


@pytest.mark.parametrize("mode", ["peer", "client"])
def test_a_stack_file_over_two_hosts_poses_every_frame(
    hosts: Hosts, data_dir: Path, models: dict[str, list[str]], tmp_path: Path, mode: str,
) -> None:
    stack = stack_file(tmp_path, hosts, mode, models)
    router = RouterProcess(["--listen", f"tcp/{hosts.compute_ip}:7447"], REPO_ROOT,
                           prefix=hosts.exec_prefix(hosts.compute))
    try:
        compute = run_host(hosts, hosts.compute, stack, "compute")
        camera = run_host(hosts, hosts.cam, stack, "camera", "--video",
                          str(data_dir / "videos" / "single_face.mp4"))
        code_cam, out_cam = _finish(camera, RUN_TIMEOUT)
        code_compute, out_compute = _finish(compute, 60)
    finally:
        router.stop()
    assert code_cam == 0, out_cam[-3000:]
    assert code_compute == 0, out_compute[-3000:]
    for host in ("camera", "compute"):
        summary = json.loads(stack.with_suffix(f".{host}.json").read_text())
        assert summary["total_frames"] == 72, (host, summary)
        assert summary["frames_with"]["fit"] == 72 and summary["frames_with"]["pose"] == 72
        assert summary["unanswered"] == {"fit": 0, "pose": 0}
        assert summary["ignored"].get("bad signature", 0) == 0  # the hosts share the keys
        assert set(summary["services"]) == {"source", *COMPUTE_SERVICES}, host


def test_a_host_that_never_joins_is_named_within_the_start_timeout(
    hosts: Hosts, data_dir: Path, models: dict[str, list[str]], tmp_path: Path,
) -> None:
    stack = stack_file(tmp_path, hosts, "peer", models)
    router = RouterProcess(["--listen", f"tcp/{hosts.compute_ip}:7447"], REPO_ROOT,
                           prefix=hosts.exec_prefix(hosts.compute))
    started = time.monotonic()
    try:
        camera = run_host(hosts, hosts.cam, stack, "camera", "--video",
                          str(data_dir / "videos" / "single_face.mp4"), "--start-timeout", "3")
        code, out = _finish(camera, 120)
    finally:
        router.stop()
    assert code == 1, out[-3000:]
    assert ("error: host compute (detector, fitter, pose, expression) of the stack file never "
            "joined: not heard from within 3 s") in out, out[-3000:]
    assert time.monotonic() - started < 60
