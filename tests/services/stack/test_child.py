"""services.stack.child: a service process ends as soon as its ``main`` returns."""

from __future__ import annotations

import subprocess
from pathlib import Path

from aamcore.config import REPO_ROOT
from services.stack.supervisor import child_command, child_environment

SERVICE = "tests.services.stack.quick_exit_service"


def run_child(*argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(child_command(SERVICE, list(argv)), env=child_environment({}),
                          cwd=REPO_ROOT, capture_output=True, text=True, timeout=120)


def test_a_returned_main_ends_the_process_without_the_interpreters_teardown(
    tmp_path: Path,
) -> None:
    marks = tmp_path / "marks"
    done = run_child(str(marks))
    assert done.returncode == 3, done.stderr
    # What it printed and logged is out, though nothing of the teardown ran.
    assert done.stdout == "printed\n" and "logged" in done.stderr
    assert not marks.exists(), "the interpreter's exit handlers ran"


def test_an_exception_in_main_takes_the_interpreters_own_way_out(tmp_path: Path) -> None:
    marks = tmp_path / "marks"
    done = run_child(str(marks), "raise")
    assert done.returncode == 1
    assert "RuntimeError: main failed" in done.stderr and "logged" in done.stderr
    assert marks.read_text() == "teardown\n"  # the positive control of the test above
