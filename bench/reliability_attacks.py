"""The attacks of issue 37 on a real run, by a program of the same user on the run's bus: each
a case of bench/bench_reliability.py (``--only hostile``), which runs it many times.

Every case runs the default services (no AR) on ``single_face.mp4`` played three times in
real time (216 frames). A case passes when every message of the attack is ignored and
counted, by its reason, in the launcher's summary, the run reaches its end and its exit
code tells the truth: 0, or 1 where the case kills the fitter (the frames it missed are
owed whatever the attacker says).

Without the run's keys:

- ``forged status``: the fitter killed, then a ``Status`` in its name (77 restarts, 100000
  dropped) every 0.1 s until the run ends;
- ``forged no-face fits``: the fitter killed, then a failed "no face" fit in its name for
  every frame;
- ``status of another run``: ``status/fitter`` of run ``run-000000000000`` every 0.1 s
  from before the first fit until fits flow;
- ``header, other pixels``: each of 20 real frames sent again with black pixels under its
  signed header; ``replayed frames``: the same 20 frames sent again as they were;
- ``forged fits``: a fit in the fitter's name for each of 20 real frames, and one of 3
  landmarks claiming 2 faces;
- ``ghost status``: statuses of a service the run does not have;
- ``another run's key``: frames, fits, a status and an end of stream signed with the keys
  of another run; ``truncated signature``: an end of stream whose signature is cut short.

With access to the run's processes (``/proc/<pid>/environ``, ``cmdline``, ``fd``, as the
same user; here as root, who sees more):

- ``env: end of stream``: every key-like value found there signs an end of stream at
  frame 10 (and one goes unsigned);
- ``env: frame 10^7``: the same with a frame numbered 10 000 000.
"""

from __future__ import annotations

import os
import re
import signal
import stat
import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from proto import EndOfStream, Fit, Frame, Header, Status, decode, encode
from proto.auth import KEY_BYTES, Keyring
from services.bus.qos import MUST_ARRIVE
from services.bus.session import Service
from services.stack.launcher import Stack
from services.stack.outcome import EXIT_FAILED, EXIT_OK, exit_code

Hook = Callable[[Stack, Service], None]
Run = Callable[..., tuple[Stack, dict]]
"""``run(argv, during, after=None)``: a real run with an intruder on its bus; ``during`` is
called once the stack started, ``after`` once it ended (the launcher still counting)."""
FORGED = 20
"""Messages of each kind a case forges from the real ones."""


def _status(stream: str, run: str, service: str, restarts: int = 77) -> Status:
    return Status(Header.now(stream, 5, service, run_id=run), service=service, state="running",
                  frames_in=5, frames_out=5, dropped=100_000, rejected=0, lost=0, ignored=0,
                  failed=0, latency_p50_ms=1.0, latency_p99_ms=2.0, restarts=restarts,
                  message="")


def _fit(stream: str, run: str, index: int, points: int = 68, faces: int = 1,
         failed: bool = False) -> Fit:
    landmarks = (np.zeros((0, 2), np.float32) if failed else
                 np.full((points, 2), 100.0, np.float32) + np.arange(points)[:, None])
    return Fit(Header.now(stream, index, "fitter", run_id=run), "ibug68", landmarks,
               np.array([1.0, 0.0, 0.0, 0.0], np.float32), 640, 360, failed,
               "no face" if failed else "", 0.5, "none", None, faces=faces)


def _wait(condition: Callable[[], bool], timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.02)


class Sender:
    """Puts the attack's messages so that they arrive, counting them by the reason the
    run must ignore them for."""

    def __init__(self, intruder: Service) -> None:
        self.intruder = intruder
        self.sent: dict[str, int] = {}

    def put(self, reason: str, key: str, payload: bytes) -> None:
        self.intruder.put(key, payload, MUST_ARRIVE)
        self.sent[reason] = self.sent.get(reason, 0) + 1


def _frames(intruder: Service, count: int) -> list[bytes]:
    """Capture the next ``count`` real frames, as they travel."""
    got: list[bytes] = []
    lock = threading.Lock()

    def keep(sample: object) -> None:
        with lock:
            if len(got) < count:
                got.append(sample.payload.to_bytes())  # type: ignore[attr-defined]

    intruder.subscribe(intruder.key("frame"), keep)
    _wait(lambda: len(got) >= count)
    return got


def _counted(stack: Stack, sent: dict[str, int], rejected: int = 0) -> bool:
    """Wait until the launcher has counted every message sent, by reason."""
    by = stack.service.stats.ignored_by
    _wait(lambda: all(by[r] >= n for r, n in sent.items())
          and stack.service.stats.rejected >= rejected)
    return all(by[r] >= n for r, n in sent.items())


def _verdict(summary: dict, sent: dict[str, int], code: int, extra: bool = True,
             note: str = "") -> tuple[bool, str]:
    counted = all(summary["ignored"].get(r, 0) >= n for r, n in sent.items())
    got = exit_code(summary["outcome"], summary)
    ok = counted and got == code and summary["outcome"] == "done" and extra
    said = ", ".join(f"{summary['ignored'].get(r, 0)} {r}" for r in sent)
    return ok, (f"exit {got} (true: {code}); ignored {said}; {summary['frames_with']['fit']} of "
                f"{summary['total_frames']} frames fitted{note}")


def _kill_fitter(stack: Stack) -> None:
    _wait(lambda: stack.monitor.counts["fit"] >= 10)
    pid = stack.supervisor.pid("fitter")
    if pid is not None:
        os.kill(pid, signal.SIGKILL)


def _until_end(stack: Stack, every: float, send: Callable[[int], None]) -> threading.Thread:
    """Call ``send(k)`` every ``every`` s in a thread until the run's end of stream."""

    def loop() -> None:
        k = 0
        while stack.monitor.eos is None and not stack.service.stopping:
            send(k)
            k += 1
            time.sleep(every)

    thread = threading.Thread(target=loop, daemon=True)
    thread.start()
    return thread


def forged_status(run: Run, argv: list[str]) -> tuple[bool, str]:
    box: dict[str, Sender] = {}

    def during(stack: Stack, intruder: Service) -> None:
        s = box["s"] = Sender(intruder)
        _kill_fitter(stack)
        key = f"aamtrack/{intruder.stream}/status/fitter"
        box["thread"] = _until_end(stack, 0.1, lambda k: s.put("unsigned", key, encode(
            _status(intruder.stream, stack.run_id, "fitter"))))

    def after(stack: Stack, intruder: Service) -> None:
        box["thread"].join(10)
        _counted(stack, box["s"].sent)

    stack, summary = run(argv, during, after)
    fitter = summary["services"]["fitter"]
    return _verdict(summary, box["s"].sent, EXIT_FAILED,
                    fitter["restarts"] == 1 and fitter["dropped"] < 100_000,
                    f", fitter restarts {fitter['restarts']}")


def forged_no_face_fits(run: Run, argv: list[str]) -> tuple[bool, str]:
    box: dict[str, Sender] = {}

    def during(stack: Stack, intruder: Service) -> None:
        s = box["s"] = Sender(intruder)
        _kill_fitter(stack)
        for index in range(216):
            s.put("unsigned", intruder.key("fit"),
                  encode(_fit(intruder.stream, stack.run_id, index, failed=True)))
        _counted(stack, s.sent)

    _, summary = run(argv, during)
    return _verdict(summary, box["s"].sent, EXIT_FAILED, summary["fits_no_face"] == 0)


def status_of_another_run(run: Run, argv: list[str]) -> tuple[bool, str]:
    box: dict[str, Sender] = {}

    def during(stack: Stack, intruder: Service) -> None:
        s = box["s"] = Sender(intruder)
        key = f"aamtrack/{intruder.stream}/status/fitter"
        while stack.monitor.counts["fit"] < 10 and not stack.service.stopping:
            s.put("another run", key, encode(_status(intruder.stream, "run-000000000000",
                                                     "fitter")))
            time.sleep(0.1)
        _counted(stack, s.sent)

    _, summary = run(argv, during)
    return _verdict(summary, box["s"].sent, EXIT_OK,
                    "run-000000000000" in summary["foreign_runs"])


def header_other_pixels(run: Run, argv: list[str]) -> tuple[bool, str]:
    return _with_frames(run, argv, lambda real: [("bad signature", encode(Frame.from_array(
        real.header, np.zeros((real.height, real.width, 3), np.uint8))))])


def replayed_frames(run: Run, argv: list[str]) -> tuple[bool, str]:
    return _with_frames(run, argv, lambda real: [("replayed", None)])


def _with_frames(run: Run, argv: list[str],
                 forge: Callable[[Frame], list[tuple[str, bytes | None]]]) -> tuple[bool, str]:
    box: dict[str, Sender] = {}

    def during(stack: Stack, intruder: Service) -> None:
        s = box["s"] = Sender(intruder)
        for payload in _frames(intruder, FORGED):
            for reason, forged in forge(decode(payload, "frame")):
                s.put(reason, intruder.key("frame"), payload if forged is None else forged)
        _counted(stack, s.sent)

    _, summary = run(argv, during)
    fitter = summary["services"]["fitter"]
    return _verdict(summary, box["s"].sent, EXIT_OK,
                    summary["messages"]["fit"] == summary["frames_with"]["fit"]
                    and fitter["ignored"] >= FORGED,
                    f", {summary['messages']['fit']} fits, fitter ignored {fitter['ignored']}")


def forged_fits(run: Run, argv: list[str]) -> tuple[bool, str]:
    box: dict[str, Sender] = {}

    def during(stack: Stack, intruder: Service) -> None:
        s = box["s"] = Sender(intruder)
        for payload in _frames(intruder, FORGED):
            index = decode(payload, "frame").header.frame_index
            s.put("unsigned", intruder.key("fit"), encode(_fit(intruder.stream, stack.run_id,
                                                               index)))
        s.put("unsigned", intruder.key("fit"), encode(_fit(intruder.stream, stack.run_id, 30,
                                                           points=3, faces=2)))
        _counted(stack, s.sent)

    _, summary = run(argv, during)
    expression = summary["services"]["expression"]
    return _verdict(summary, box["s"].sent, EXIT_OK,
                    summary["messages"]["fit"] == summary["frames_with"]["fit"]
                    and expression["state"] != "degraded" and expression["dropped"] == 0,
                    f", {summary['messages']['fit']} fits, expression {expression['state']}, "
                    f"{expression['dropped']} without their frame")


def ghost_status(run: Run, argv: list[str]) -> tuple[bool, str]:
    box: dict[str, Sender] = {}

    def during(stack: Stack, intruder: Service) -> None:
        s = box["s"] = Sender(intruder)
        _wait(lambda: stack.monitor.counts["fit"] >= 10)
        for _ in range(FORGED):
            s.put("not a service of the run", f"aamtrack/{intruder.stream}/status/ghost",
                  encode(_status(intruder.stream, stack.run_id, "ghost")))
        _counted(stack, s.sent)

    _, summary = run(argv, during)
    return _verdict(summary, box["s"].sent, EXIT_OK, "ghost" not in summary["services"])


def another_runs_key(run: Run, argv: list[str]) -> tuple[bool, str]:
    box: dict[str, Sender] = {}

    def during(stack: Stack, intruder: Service) -> None:
        s = box["s"] = Sender(intruder)
        other = Keyring.generate(["source", "fitter"])
        source, fitter = other.for_service("source"), other.for_service("fitter")
        stream, run_id = intruder.stream, stack.run_id
        _wait(lambda: stack.monitor.counts["fit"] >= 10)
        for k in range(FORGED):
            frame = Frame.from_array(Header.now(stream, 100 + k, "source", run_id=run_id),
                                     np.zeros((360, 640, 3), np.uint8))
            s.put("bad signature", intruder.key("frame"), source.encode(frame))
            s.put("bad signature", intruder.key("fit"), fitter.encode(_fit(stream, run_id, k)))
        s.put("bad signature", f"aamtrack/{stream}/status/fitter",
              fitter.encode(_status(stream, run_id, "fitter")))
        eos = EndOfStream(Header.now(stream, 10, "source", run_id=run_id), 11, "end_of_file")
        s.put("bad signature", intruder.key("eos"), source.encode(eos))
        _counted(stack, s.sent)

    _, summary = run(argv, during)
    return _verdict(summary, box["s"].sent, EXIT_OK, summary["total_frames"] == 216)


def truncated_signature(run: Run, argv: list[str]) -> tuple[bool, str]:
    def during(stack: Stack, intruder: Service) -> None:
        _wait(lambda: stack.monitor.counts["fit"] >= 10)
        eos = EndOfStream(Header.now(intruder.stream, 10, "source", run_id=stack.run_id), 11,
                          "end_of_file")
        payload = Keyring.generate(["source"]).for_service("source").encode(eos)
        auth = decode(payload).header.auth
        cut = payload.replace(b"\xd9\x80" + auth.encode(), b"\xd9\x7f" + auth[:127].encode(),
                              1)
        intruder.put(intruder.key("eos"), cut, MUST_ARRIVE)
        _counted(stack, {}, rejected=1)

    _, summary = run(argv, during)
    ok, said = _verdict(summary, {}, EXIT_OK, summary["rejected"] >= 1
                        and summary["total_frames"] == 216)
    return ok, f"{said}; {summary['rejected']} malformed (rejected)"


_HEX = re.compile(rb"(?<![0-9a-f])[0-9a-f]{32,64}(?![0-9a-f])")


def stolen_keys(stack: Stack) -> tuple[list[bytes], str]:
    """Every key-like value in the run's processes' environments and command lines, and
    whether a key channel could still be opened (a pipe, as in contract v6; a socket cannot
    be): what a same-user process can read there."""
    found: set[bytes] = set()
    pipes = 0
    for spec in stack.specs:
        pid = stack.supervisor.pid(spec.name)
        if pid is None:
            continue
        for part in ("environ", "cmdline"):
            try:
                text = Path(f"/proc/{pid}/{part}").read_bytes()
            except OSError:
                continue
            found |= {bytes.fromhex(m.decode()) for m in _HEX.findall(text)}
        args = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
        if len(args) > 5 and args[5].isdigit():  # python -m services.stack.child M NICE FD
            try:
                path = f"/proc/{pid}/fd/{int(args[5])}"
                if stat.S_ISFIFO(os.stat(path).st_mode):
                    with open(path, "rb") as pipe:
                        found.add(pipe.read(4096))
                        pipes += 1
            except OSError:
                pass
    keys = [k for k in found if len(k) == KEY_BYTES]
    return keys, f"{len(keys)} keys in environments and command lines, {pipes} key pipes open"


def _env_attack(run: Run, argv: list[str], forge: Callable[[Stack, Service, Keyring], bytes],
                kind: str) -> tuple[dict, str, dict[str, int]]:
    box: dict = {}

    def during(stack: Stack, intruder: Service) -> None:
        s = box["s"] = Sender(intruder)
        _wait(lambda: stack.monitor.counts["fit"] >= 10)
        keys, box["note"] = stolen_keys(stack)
        for key in keys:
            s.put("bad signature", intruder.key(kind),
                  forge(stack, intruder, Keyring.from_secrets({"source": key}, "source")))
        unsigned = forge(stack, intruder, Keyring())
        s.put("unsigned", intruder.key(kind), unsigned)
        _counted(stack, s.sent)

    _, summary = run(argv, during)
    return summary, box["note"], box["s"].sent


def env_end_of_stream(run: Run, argv: list[str]) -> tuple[bool, str]:
    def forge(stack: Stack, intruder: Service, ring: Keyring) -> bytes:
        eos = EndOfStream(Header.now(intruder.stream, 103, "source", run_id=stack.run_id), 104,
                          "end_of_file")
        return ring.encode(eos) if ring else encode(eos)

    summary, note, sent = _env_attack(run, argv, forge, "eos")
    ok, said = _verdict(summary, sent, EXIT_OK, summary["total_frames"] == 216)
    return ok, f"{said}; {note}"


def env_frame_far_ahead(run: Run, argv: list[str]) -> tuple[bool, str]:
    def forge(stack: Stack, intruder: Service, ring: Keyring) -> bytes:
        frame = Frame.from_array(Header.now(intruder.stream, 10_000_000, "source",
                                            run_id=stack.run_id),
                                 np.zeros((360, 640, 3), np.uint8))
        return ring.encode(frame) if ring else encode(frame)

    summary, note, sent = _env_attack(run, argv, forge, "frame")
    fitter = summary["services"]["fitter"]
    ok, said = _verdict(summary, sent, EXIT_OK, fitter["lost"] == 0
                        and summary["messages"]["fit"] == summary["frames_with"]["fit"])
    return ok, f"{said}; fitter lost {fitter['lost']}; {note}"


ATTACKS: dict[str, Callable[[Run, list[str]], tuple[bool, str]]] = {
    "forged status": forged_status,
    "forged no-face fits": forged_no_face_fits,
    "status of another run": status_of_another_run,
    "header, other pixels": header_other_pixels,
    "replayed frames": replayed_frames,
    "forged fits": forged_fits,
    "ghost status": ghost_status,
    "another run's key": another_runs_key,
    "truncated signature": truncated_signature,
    "env: end of stream": env_end_of_stream,
    "env: frame 10^7": env_frame_far_ahead,
}
"""Case name -> case (``ATTACKS[name](run, argv)``, with ``run`` the cases' stack runner)."""
