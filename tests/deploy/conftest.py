"""Fixtures of the deployment tests: certificates, routers, the small test model."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from aamcore.config import REPO_ROOT

DEPLOY = REPO_ROOT / "deploy"
ZENOH_DIR = DEPLOY / "zenoh"
IDENTITIES = ("router", "stack", "viewer", "rogue")
"""Certificates signed by the test CA; the common name of each is ``aamtrack-<name>``."""
MODEL_LIMIT = 300
MODEL_IMAGES = 10
CLASSIFIER_LIMIT = 10
ROUTER_START_TIMEOUT = 20.0


def _openssl(*args: str, cwd: Path) -> None:
    done = subprocess.run(["openssl", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=60)
    if done.returncode != 0:
        raise RuntimeError(f"openssl {' '.join(args)}: {done.stderr.strip()}")


def make_ca(folder: Path, name: str = "ca", cn: str = "aamtrack-test-ca") -> None:
    """A self-signed CA: ``folder/<name>.pem`` and ``folder/<name>.key``."""
    _openssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", f"{name}.key",
             "-out", f"{name}.pem", "-days", "2", "-subj", f"/CN={cn}", cwd=folder)


def make_cert(folder: Path, name: str, ca: str = "ca") -> None:
    """``folder/<name>.pem`` and ``.key`` for common name ``aamtrack-<name>``, signed by
    ``ca``, valid for ``localhost`` and ``127.0.0.1``."""
    _openssl("req", "-newkey", "rsa:2048", "-nodes", "-keyout", f"{name}.key", "-out",
             f"{name}.csr", "-subj", f"/CN=aamtrack-{name}", cwd=folder)
    (folder / f"{name}.ext").write_text("subjectAltName=DNS:localhost,IP:127.0.0.1\n")
    _openssl("x509", "-req", "-in", f"{name}.csr", "-CA", f"{ca}.pem", "-CAkey", f"{ca}.key",
             "-CAcreateserial", "-out", f"{name}.pem", "-days", "2", "-extfile",
             f"{name}.ext", cwd=folder)


@pytest.fixture(scope="session")
def pki(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with ``certs/``: the test CA, a certificate per :data:`IDENTITIES`, and
    ``other-ca`` with ``impostor`` (common name ``aamtrack-impostor``, another CA).

    The deploy configuration files name ``certs/...`` relative to the working directory:
    run a router or client in this folder to use them unchanged.
    """
    if shutil.which("openssl") is None:
        pytest.skip("the openssl command is not installed: cannot make test certificates")
    root = tmp_path_factory.mktemp("pki")
    certs = root / "certs"
    certs.mkdir()
    make_ca(certs)
    for name in IDENTITIES:
        make_cert(certs, name)
    make_ca(certs, "other-ca", "aamtrack-other-ca")
    make_cert(certs, "impostor", ca="other-ca")
    return root


def child_env() -> dict[str, str]:
    """Environment of a child process: the repository on the path, one compute thread."""
    return os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO_ROOT)}


class RouterProcess:
    """An ``aamtrack router`` child process, started and waited for until it listens."""

    def __init__(self, args: list[str], cwd: Path, prefix: list[str] | None = None) -> None:
        cmd = [*(prefix or []), sys.executable, "-m", "services", "router", *args]
        self.proc = subprocess.Popen(cmd, cwd=cwd, env=child_env(), stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True)
        assert self.proc.stdout is not None
        self.banner = self.proc.stdout.readline()  # blocks until it listens or exits
        if "listening on" not in self.banner:
            rest = self.proc.stdout.read() if self.proc.poll() is not None else ""
            self.stop()
            raise RuntimeError(f"router did not start: {self.banner}{rest}")

    def stop(self) -> str:
        """SIGTERM (SIGKILL after 10 s); the rest of its output."""
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)
        assert self.proc.stdout is not None
        if self.proc.stdout.closed:
            return ""
        out = self.proc.stdout.read()
        self.proc.stdout.close()
        return out


@pytest.fixture
def start_router() -> Iterator[Callable[..., RouterProcess]]:
    """``start_router(args, cwd)``: an ``aamtrack router`` child, stopped after the test."""
    started: list[RouterProcess] = []

    def start(args: list[str], cwd: Path = REPO_ROOT,
              prefix: list[str] | None = None) -> RouterProcess:
        router = RouterProcess(args, cwd, prefix)
        started.append(router)
        return router

    yield start
    for router in started:
        router.stop()


def client_config(mode: str, connect: str, tls: dict[str, Any] | None = None,
                  listen: str | None = None) -> Any:
    """A ``zenoh.Config`` connecting to ``connect``, with ``transport/link/tls`` = ``tls``."""
    from proto.zenoh_config import zenoh_config

    cfg = zenoh_config(mode, [listen] if listen else [], [connect])
    if tls is not None:
        cfg.insert_json5("transport/link/tls", json.dumps(tls))
    return cfg


class Probe:
    """A Zenoh session that records what its subscriber receives; closed by :meth:`close`."""

    def __init__(self, config: Any, key: str | None = None) -> None:
        import zenoh

        self.session = zenoh.open(config)
        self.received: list[bytes] = []
        self._sub = (self.session.declare_subscriber(key, self._on) if key is not None
                     else None)

    def _on(self, sample: Any) -> None:
        self.received.append(sample.payload.to_bytes())

    def close(self) -> None:
        if self._sub is not None:
            self._sub.undeclare()
        self.session.close()


def wait_until(predicate: Callable[[], bool], timeout: float) -> bool:
    """Poll ``predicate`` every 20 ms until it holds or ``timeout`` s pass."""
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() >= deadline:
            return False
        time.sleep(0.02)
    return True


def publish_until_received(publisher: Any, key: str, probe: Probe, tag: bytes,
                           timeout: float = 5.0) -> bool:
    """Put ``tag`` + a counter on ``key`` every 50 ms until ``probe`` got one; whether it did.

    Repeating covers the moments it takes a subscription to travel through a router.
    """
    deadline = time.monotonic() + timeout
    n = 0
    while time.monotonic() < deadline:
        publisher.put(key, tag + str(n).encode())
        n += 1
        if wait_until(lambda: any(r.startswith(tag) for r in probe.received), 0.05):
            return True
    return False


@pytest.fixture(scope="session")
def models() -> dict[str, list[str]]:
    """Model arguments per service for the small cached LFPW AAM (trained on first use)."""
    from aamcore.expression.training import classifier_path
    from aamcore.fitting.training.prepare import default_model_path

    path = default_model_path(max_images=MODEL_IMAGES, limit=MODEL_LIMIT)
    return {"fitter": ["--model", str(path)],
            "expression": ["--model", str(path), "--classifier",
                           str(classifier_path(path, limit=CLASSIFIER_LIMIT))]}
