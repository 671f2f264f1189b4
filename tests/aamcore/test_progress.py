"""aamcore.progress: bars on a terminal, lines elsewhere, nothing when asked."""

from __future__ import annotations

import pytest

from aamcore import progress


def test_without_a_terminal_each_phase_says_when_it_starts_and_ends(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("AAMTRACK_PROGRESS", raising=False)
    assert progress.mode() == "lines"  # pytest's captured stderr is no terminal
    assert list(progress.bar("face detection")(range(7))) == list(range(7))
    lines = capsys.readouterr().err.splitlines()
    assert lines[0] == "aamtrack: face detection: started (7 items)"
    assert lines[-1].startswith("aamtrack: face detection: done (7 items in ")
    monkeypatch.setattr(progress, "LINE_EVERY_S", 0.0)
    list(progress.progress(range(8), "fern stages"))
    quarters = [line for line in capsys.readouterr().err.splitlines() if "%" in line]
    assert [q.split(": ")[2].split()[0] for q in quarters] == ["25%", "50%", "75%", "100%"]


def test_progress_can_be_turned_off(capsys: pytest.CaptureFixture[str],
                                    monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("AAMTRACK_PROGRESS", "0")
    assert list(progress.progress(iter(range(3)), "x")) == [0, 1, 2]
    assert capsys.readouterr().err == "" and not progress.enabled()
