"""aamcore.progress: bars on a terminal, lines elsewhere, nothing when asked; phases
numbered with the time left; no long silence."""

from __future__ import annotations

import time

import pytest

from aamcore import progress


@pytest.fixture(autouse=True)
def _lines(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("AAMTRACK_PROGRESS", raising=False)


def _slow(n: int, seconds: float):
    for k in range(n):
        time.sleep(seconds)
        yield k


def test_without_a_terminal_a_line_says_when_work_starts_and_ends(
    capsys: pytest.CaptureFixture[str]
) -> None:
    assert progress.mode() == "lines"  # pytest's captured stderr is no terminal
    assert list(progress.bar("face detection")(range(7))) == list(range(7))
    lines = capsys.readouterr().err.splitlines()
    assert lines[0] == "aamtrack: face detection: started (7 items)"
    assert lines[-1].startswith("aamtrack: face detection: done, 7 items in ")


def test_lines_at_intervals_give_the_count_the_rate_and_the_time_left(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Items of 0.3 s, a line every 0.1 s (~1 s)."""
    monkeypatch.setattr(progress, "LINE_EVERY_S", 0.1)
    rows = list(progress.progress(_slow(3, 0.3), "tracking a.mp4", total=3, unit="frame",
                                  summary=False))
    assert rows == [0, 1, 2]
    lines = capsys.readouterr().err.splitlines()
    assert lines[0] == "aamtrack: tracking a.mp4: started (3 frames)"
    counted = [line for line in lines if " of 3 frames (" in line and "frames/s" in line]
    assert counted and all(" left" in line for line in counted)
    assert not any("done" in line for line in lines)  # summary=False: the command says it


def test_a_slow_step_is_never_silent(capsys: pytest.CaptureFixture[str],
                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """One item, or a phase without items, lasting 6 periods: lines in between (~1.2 s)."""
    monkeypatch.setattr(progress, "LINE_EVERY_S", 0.1)
    with progress.plan("training", (("stages", 1.0), ("occlusion test", 1.0))):
        list(progress.bar("stages")(_slow(1, 0.6)))
        with progress.phase("occlusion test"):
            time.sleep(0.6)
    lines = capsys.readouterr().err.splitlines()
    during = [k for k, line in enumerate(lines) if "phase 2 of 2: occlusion test" in line]
    assert len(during) >= 3 and "in all" in lines[during[-1]]
    first = [line for line in lines if "phase 1 of 2: stages" in line]
    assert len(first) >= 3  # started, at least one while the one item ran, done
    assert lines[-1].startswith("aamtrack: training: done in ")


def test_phases_are_numbered_and_the_time_left_follows_the_pace() -> None:
    now = [0.0]
    plan = progress.Plan("job", (("a", 10.0), ("b", 20.0), ("c", 30.0)), clock=lambda: now[0])
    assert plan.left() == 60.0
    assert plan.start("a") == "job, phase 1 of 3: a"
    now[0] = 20.0  # a took twice as long as expected: the rest will too
    assert plan.start("c") == "job, phase 2 of 2: c"  # b was skipped
    assert plan.left() == 60.0
    assert plan.left(share_done=0.5) == 0.0 + 0.0 + 0.0  # half of c in no time: none left
    now[0] = 50.0
    assert plan.left(share_done=0.5) == 30.0
    assert plan.start("d") == "job, phase 3 of 3: d"  # not planned: counted all the same
    assert progress.duration(125) == "2 min 05 s" and progress.duration(3720) == "1 h 02 min"


def test_progress_can_be_turned_off(capsys: pytest.CaptureFixture[str],
                                    monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("AAMTRACK_PROGRESS", "0")
    assert list(progress.progress(iter(range(3)), "x")) == [0, 1, 2]
    with progress.plan("y", (("x", 1.0),)):
        list(progress.progress(iter(range(3)), "x"))
    assert capsys.readouterr().err == "" and not progress.enabled()


def test_interrupted_work_is_not_said_to_be_done(capsys: pytest.CaptureFixture[str]) -> None:
    def interrupted():
        yield 1
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt), progress.plan("training", (("stages", 1.0),)):
        list(progress.bar("stages")(interrupted()))
    assert not [line for line in capsys.readouterr().err.splitlines() if "done" in line]
