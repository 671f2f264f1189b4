"""services.bus.trust and the screen of a run with keys: each bad input ignored and counted
by its reason, one index answered once, a restarted service's floors, state bounded; a keys
file's owner, mode and keys checked; keys reach a process only once it is non-dumpable.

The screen is a plain function of the payload, so these tests call it directly: no bus,
no timing.
"""

from __future__ import annotations

import json
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from proto import EndOfStream, Fit, Frame, Header, Status, encode
from proto.auth import Keyring
from services.bus.connection import BusOptions
from services.bus.inbox import Screen
from services.bus.session import Service
from services.bus.stats import ServiceStats
from services.bus.trust import (
    MAX_STREAMS,
    Replays,
    read_keys_file,
    write_keys_file,
)
from services.stack.supervisor import ServiceSpec, Supervisor

RUN = "run-test"
RING = Keyring.generate(["source", "fitter", "pose"])


def _screen(stats: ServiceStats, rejected: list[str], run: str = RUN,
            floors: dict | None = None) -> Screen:
    return Screen("cam0", run, stats, lambda source, reason: rejected.append(reason),
                  RING.for_service("pose"), floors=floors)


def _frame(index: int, image: np.ndarray | None = None, run: str = RUN) -> Frame:
    pixels = np.full((24, 32, 3), index % 256, np.uint8) if image is None else image
    return Frame.from_array(Header.now("cam0", index, "source", run_id=run), pixels)


def _fit(index: int, producer: str = "fitter", faces: int = 1) -> Fit:
    landmarks = np.tile(np.arange(68, dtype=np.float32)[:, None], (1, 2))
    return Fit(Header.now("cam0", index, producer, run_id=RUN), "ibug68", landmarks,
               np.ones(4, np.float32), 32, 24, False, "", 0.5, "none", None, faces=faces)


def _status(service: str, dropped: int = 0) -> Status:
    return Status(Header.now("cam0", 5, service, run_id=RUN), service=service, state="running",
                  frames_in=5, frames_out=5, dropped=dropped, rejected=0, lost=0, ignored=0,
                  failed=0, latency_p50_ms=1.0, latency_p99_ms=2.0, restarts=77, message="")


def _signed(name: str, message: object) -> bytes:
    return RING.for_service(name).encode(message)  # type: ignore[arg-type]


def test_each_bad_input_is_ignored_and_counted_by_its_reason() -> None:
    stats, rejected = ServiceStats(), []
    screen, replays = _screen(stats, rejected), Replays()
    frame, fit, status = "aamtrack/cam0/frame", "aamtrack/cam0/fit", "aamtrack/cam0/status/"
    real = _signed("source", _frame(3))
    assert screen.check(real, frame, "frame", replays) is not None
    other_run = Keyring.generate(["source", "fitter"])
    black = replace(_frame(3, np.zeros((24, 32, 3), np.uint8)), header=_decoded_header(real))
    cases = [  # (reason, key, payload)
        ("bad signature", frame, other_run.for_service("source").encode(_frame(4))),
        ("bad signature", frame, encode(black)),  # the real frame's header on other pixels
        ("unsigned", fit, encode(_fit(3))),
        ("unsigned", status + "fitter", encode(_status("fitter", dropped=100_000))),
        ("replayed", frame, real),
        ("not a service of the run", status + "ghost", _signed("pose", _status("ghost"))),
        ("not its key's owner", fit, _signed("pose", _fit(5, producer="pose"))),
        ("another run", frame, _signed("source", _frame(6, run="run-000000000000"))),
    ]
    for reason, key, payload in cases:
        kind = "status" if key.startswith(status) else key.rsplit("/", 1)[-1]
        assert screen.check(payload, key, kind, replays) is None, reason
    counted: dict[str, int] = {}
    for reason, _, _ in cases:
        counted[reason] = counted.get(reason, 0) + 1
    assert dict(stats.ignored_by) == counted and stats.ignored == len(cases)
    assert not rejected
    # A signature cut short is malformed: rejected (the callback counts it), never acted on.
    auth = _decoded_header(real).auth
    cut = real.replace(b"\xd9\x80" + auth.encode(), b"\xd9\x7f" + auth[:127].encode(), 1)
    assert screen.check(cut, frame, "frame", replays) is None
    assert len(rejected) == 1 and "header.auth" in rejected[0]


def test_a_stale_message_of_the_run_is_ignored() -> None:
    stats, rejected = ServiceStats(), []
    old = _frame(1)
    old = replace(old, header=replace(old.header, publish_time_ns=time.time_ns() - 61 * 10**9))
    assert _screen(stats, rejected).check(_signed("source", old), "aamtrack/cam0/frame",
                                          "frame", Replays()) is None
    assert stats.ignored_by == {"stale": 1}


def _decoded_header(payload: bytes) -> Header:
    from proto import decode

    return decode(payload).header


def test_one_index_is_answered_once_and_the_memory_of_indices_is_bounded() -> None:
    replays = Replays(window=8)
    fits = [_fit(i) for i in range(20)]
    assert all(replays.first(f) for f in fits)
    assert not replays.first(fits[19]) and not replays.first(fits[3])  # seen; too old
    assert replays.first(replace(fits[19], face_id=1))  # the frame's second face
    eos = EndOfStream(Header.now("cam0", 19, "source", run_id=RUN), 20, "end_of_file")
    assert replays.first(eos) and not replays.first(eos)  # one end of stream per run
    window = next(iter(replays._streams.values()))
    assert len(window.seen) <= 8 and len(window.order) <= 8
    for k in range(3 * MAX_STREAMS):  # runs without end: the streams followed stay bounded
        replays.first(replace(eos, header=replace(eos.header, run_id=f"run-{k}")))
    assert len(replays._streams) <= MAX_STREAMS


def test_a_restarted_service_refuses_what_its_run_had_reached() -> None:
    """The frames a dead fitter missed, replayed unchanged to the new one, are refused."""
    stats, rejected = ServiceStats(), []
    screen = _screen(stats, rejected, floors={("source", "frame"): 9, ("fitter", "fit"): 4})
    replays = Replays()
    old, new = _signed("source", _frame(9)), _signed("source", _frame(10))
    assert screen.check(old, "aamtrack/cam0/frame", "frame", replays) is None
    assert screen.check(_signed("fitter", _fit(4)), "aamtrack/cam0/fit", "fit", replays) is None
    assert screen.check(new, "aamtrack/cam0/frame", "frame", replays) is not None  # control
    assert screen.check(_signed("fitter", _fit(5)), "aamtrack/cam0/fit", "fit",
                        replays) is not None
    assert stats.ignored_by == {"before the restart": 2}
    # A frame sent while no process listened (after the floors, before it subscribed).
    early = _signed("source", _frame(11))
    screen.restarted = True
    screen.subscribing()
    assert screen.check(early, "aamtrack/cam0/frame", "frame", replays) is None
    assert screen.check(_signed("source", _frame(12)), "aamtrack/cam0/frame", "frame",
                        replays) is not None
    assert stats.ignored_by == {"before the restart": 3}


def test_a_keys_file_must_be_the_users_closed_to_others_with_keys_of_their_length(
    tmp_path: Path,
) -> None:
    path = tmp_path / "run.keys"
    write_keys_file(path, RING)
    assert read_keys_file(path) == RING
    assert read_keys_file(path, "pose") == RING.for_service("pose")
    assert read_keys_file(path, "reader") == RING.public_only()
    with pytest.raises(FileExistsError):
        write_keys_file(path, RING)
    path.chmod(0o640)
    with pytest.raises(ValueError, match=f"keys file {path}: mode 640: others may read"):
        read_keys_file(path)
    path.chmod(0o600)
    os.chown(path, 65534, -1)  # another user's (the test runs as root, who may give it)
    with pytest.raises(ValueError, match=f"keys file {path}: owned by uid 65534"):
        read_keys_file(path)
    link = tmp_path / "link.keys"
    link.symlink_to(path)
    with pytest.raises(ValueError, match=f"keys file {link}: a symbolic link"):
        read_keys_file(link)
    short = tmp_path / "short.keys"
    data = json.loads(RING.to_bytes())
    data["secret"]["pose"] = data["secret"]["pose"][:60]
    fd = os.open(short, os.O_WRONLY | os.O_CREAT, 0o600)
    os.write(fd, json.dumps(data).encode())
    os.close(fd)
    with pytest.raises(ValueError, match=f"keys file {short}: .*pose.* is not 32 bytes"):
        read_keys_file(short)


PROBE = '''
import json, os, sys
from services.bus import trust
from services.bus.session import Service
from services.bus.connection import BusOptions

def main(argv):
    import ctypes
    ring = Service("pose", BusOptions("cam0")).keyring
    dumpable = ctypes.CDLL(None).prctl(3, 0, 0, 0, 0)  # PR_GET_DUMPABLE
    fds = sorted(os.listdir("/proc/self/fd"))
    open(argv[0], "w").write(json.dumps({"signer": ring.signer, "keys": sorted(ring.public),
                                         "secrets": sorted(ring.secrets),
                                         "dumpable": dumpable, "fds": fds}))
    import time; time.sleep(30)
'''


def test_keys_reach_a_service_once_it_is_non_dumpable_never_its_environment_or_command_line(
    tmp_path: Path,
) -> None:
    (tmp_path / "key_probe.py").write_text(PROBE)
    out = tmp_path / "probe.json"
    ring = RING.for_service("pose")
    sup = Supervisor([ServiceSpec("pose", "key_probe", [str(out)], restart=False,
                                  keyring=ring)],
                     env={"PYTHONPATH": os.pathsep.join([str(tmp_path), *sys.path])})
    sup.start()
    try:
        deadline = time.monotonic() + 60
        while not out.exists() or not out.read_text():
            assert time.monotonic() < deadline and sup.alive("pose"), "the probe never wrote"
            time.sleep(0.05)
        seen = json.loads(out.read_text())
        pid = sup.pid("pose")
        environ = Path(f"/proc/{pid}/environ").read_bytes()
        cmdline = Path(f"/proc/{pid}/cmdline").read_bytes()
    finally:
        sup.stop()
    assert seen["signer"] == "pose" and seen["keys"] == ["fitter", "pose", "source"]
    assert seen["secrets"] == ["pose"]  # its own private key, no other
    assert seen["dumpable"] == 0  # same-user processes cannot read its memory or files
    for key in RING.secrets.values():  # read as root here: no user sees more
        assert key.hex().encode() not in environ and key.hex().encode() not in cmdline
        assert key not in environ and key not in cmdline
    assert len(seen["fds"]) <= 4  # stdin, out, err, the listing's own: no key channel left


def test_a_token_without_a_signed_status_does_not_make_a_service_alive(
    bus_pair: tuple[BusOptions, BusOptions],
) -> None:
    ring = Keyring.generate(["sink", "peer"])
    with Service("peer", bus_pair[0], handle_signals=False,
                 keyring=ring.for_service("peer")) as peer:
        peer.watch_presence()
        with Service("sink", bus_pair[1], status_period=0.1, handle_signals=False) as forger:
            forger.ready()  # a liveliness token and statuses, unsigned
            # Its token and statuses reach the peer (which ignores the statuses: the positive
            # control), and still it is not alive.
            deadline = time.monotonic() + 60
            while peer.stats.ignored_by["unsigned"] < 2:
                assert time.monotonic() < deadline, "no status of the forger arrived"
                time.sleep(0.05)
            assert "sink" not in peer.alive()
        with Service("sink", bus_pair[1], handle_signals=False,
                     keyring=ring.for_service("sink")) as real:
            real.ready()
            assert peer.wait_for_alive(["sink"], 30) == []
    assert peer.stats.ignored_by["unsigned"] >= 1
