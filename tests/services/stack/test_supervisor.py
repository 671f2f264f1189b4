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


def test_stop_terminates_running_services_cleanly() -> None:
    sup = Supervisor([ServiceSpec("detector", SERVICES["detector"].module,
                                  ["--stream", "supervised", "--rate", "0"])])
    sup.start()
    wait_until(lambda: sup.alive("detector"))
    time.sleep(1.0)  # let it open its session
    started = time.monotonic()
    assert sup.stop(timeout=10) == {"detector": 0}
    assert time.monotonic() - started < 10


def test_ctrl_c_while_a_service_still_imports_does_not_kill_it(tmp_path) -> None:
    # A terminal's Ctrl-C reaches every process of the group, services still starting
    # among them: they must not die of it mid-import (a traceback, no clean stop).
    import os
    import signal

    marks = tmp_path / "marks"
    sup = Supervisor([ServiceSpec("source", "tests.services.stack.slow_start_service", [])],
                     env={"AAMTRACK_TEST_MARKS": str(marks)})
    sup.start()
    read = lambda: marks.read_text().split("\n") if marks.exists() else []  # noqa: E731
    wait_until(lambda: "importing" in read())
    os.kill(sup.pid("source"), signal.SIGINT)
    wait_until(lambda: "ready" in read())
    os.kill(sup.pid("source"), signal.SIGINT)
    wait_until(lambda: (sup.check(), sup.exitcode("source"))[1] is not None)
    assert sup.exitcode("source") == 0
    assert "stopped: signal SIGINT" in read()
