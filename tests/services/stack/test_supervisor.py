"""services.stack.supervisor: spawned service processes, restarts with back-off, clean stops."""

from __future__ import annotations

import time

from services.stack.registry import SERVICES
from services.stack.supervisor import ServiceSpec, Supervisor

SOURCE = SERVICES["source"].module


def wait_until(condition, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.05)


def test_a_crashing_service_is_restarted_with_back_off_then_given_up() -> None:
    # Missing required arguments: the source exits with code 2 at once.
    sup = Supervisor([ServiceSpec("source", SOURCE, [])], max_restarts=2, backoff=0.05)
    sup.start()
    wait_until(lambda: (sup.check(), sup.failed())[1] == ["source"])
    assert sup.restarts("source") == 2 and sup.exitcode("source") == 2
    assert [e.split(";")[0] for e in sup.events] == [
        "source died (exit 2)", "restarting source (restart 1)",
        "source died (exit 2)", "restarting source (restart 2)", "source died (exit 2)"]
    assert "gave up after 2 restarts" in sup.events[-1]
    sup.stop()


def test_a_service_that_finishes_is_not_restarted() -> None:
    sup = Supervisor([ServiceSpec("source", SOURCE, ["--help"])], backoff=0.05)
    sup.start()
    wait_until(lambda: (sup.check(), sup.exitcode("source"))[1] is not None)
    time.sleep(0.2)
    sup.check()
    assert sup.exitcode("source") == 0 and sup.restarts("source") == 0 and not sup.failed()


def test_stop_terminates_running_services_cleanly(tmp_path) -> None:
    from services.bus.connection import BusOptions
    from services.bus.session import Service

    endpoint = f"unixsock-stream/{tmp_path / 'detector.sock'}"
    sup = Supervisor([ServiceSpec("detector", SERVICES["detector"].module,
                                  ["--stream", "supervised", "--listen", endpoint])])
    sup.start()
    probe = BusOptions("supervised", connect=(endpoint,))
    with Service("probe", probe, handle_signals=False, announce=False) as svc:
        # Running, its stop handling in place: not a process still importing.
        assert svc.wait_for_alive(["detector"], 60) == []
        started = time.monotonic()
        assert sup.stop(timeout=10) == {"detector": 0}
    assert time.monotonic() - started < 10


def test_each_service_has_a_process_group_of_its_own(tmp_path) -> None:
    import os

    sup = Supervisor([ServiceSpec("source", "tests.services.stack.slow_start_service", [])],
                     env={"AAMTRACK_TEST_MARKS": str(tmp_path / "marks")})
    sup.start()
    pid = sup.pid("source")
    assert pid is not None and os.getpgid(pid) == pid != os.getpgid(0)
    sup.stop()


DRIVER = """
import signal, sys, time
from services.stack.supervisor import ServiceSpec, Supervisor
# As in a launcher started from a terminal, whatever the test runner inherited (a runner
# started in the background has SIGINT ignored, and so would this stand-in).
signal.signal(signal.SIGINT, signal.default_int_handler)
sup = Supervisor([ServiceSpec("source", "tests.services.stack.slow_start_service", [])],
                 env={"AAMTRACK_TEST_MARKS": sys.argv[1]})
sup.start()
with open(sys.argv[1], "a") as f:
    f.write("launcher waiting\\n")
try:
    time.sleep(60)
except KeyboardInterrupt:
    print("launcher interrupted", flush=True)
    print("exit", sup.stop(timeout=10)["source"], flush=True)
"""


def test_ctrl_c_reaches_the_launcher_alone_and_it_stops_a_service_still_importing(
    tmp_path,
) -> None:
    # A terminal's Ctrl-C goes to the foreground process group: the launcher's. A service
    # still importing its modules must not die of it with a KeyboardInterrupt traceback.
    import os
    import signal
    import subprocess
    import sys

    marks = tmp_path / "marks"
    driver = subprocess.Popen([sys.executable, "-c", DRIVER, str(marks)], text=True,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              start_new_session=True)
    # Both in place: the service importing, the launcher past starting it (a Ctrl-C during
    # the start is the launcher's __enter__'s to handle, not this stand-in's).
    wait_until(lambda: marks.exists() and {"importing", "launcher waiting"}
               <= set(marks.read_text().splitlines()))
    os.killpg(driver.pid, signal.SIGINT)
    out, err = driver.communicate(timeout=30)
    assert "launcher interrupted" in out
    assert "Traceback" not in err and "KeyboardInterrupt" not in err
    # Killed by the launcher's SIGTERM mid-import, or stopped cleanly just after.
    assert out.split()[-1] in ("-15", "0")
