"""aamcore.model.cache: a model wanted by several processes at once is trained once."""

from __future__ import annotations

import fcntl
import threading
from pathlib import Path

import pytest

from aamcore.model.cache import cached_file, locked
from aamcore.model.file import ModelFileError

GOOD = b"a trained model"


def _check(path: Path) -> None:
    if path.read_bytes() != GOOD:
        raise ModelFileError(f"{path}: not a model")


def _held_by_another(path: Path) -> bool:
    """Whether another open of the lock file cannot take it now."""
    with open(path.with_name(path.name + ".lock"), "a") as probe:
        try:
            fcntl.flock(probe, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return True
        fcntl.flock(probe, fcntl.LOCK_UN)
        return False


def test_the_model_is_built_under_the_lock_and_then_taken_as_it_is(tmp_path: Path) -> None:
    path = tmp_path / "model.npz"
    held: list[bool] = []

    def build(p: Path) -> Path:
        held.append(_held_by_another(p))
        p.write_bytes(GOOD)
        return p

    assert cached_file(path, build, _check) == path and held == [True]
    assert not _held_by_another(path)  # released once built
    assert cached_file(path, build, _check) == path and held == [True]  # not built again


def test_a_model_saved_while_waiting_for_the_lock_is_taken_not_trained_again(
        tmp_path: Path) -> None:
    path = tmp_path / "model.npz"
    built: list[str] = []
    done: list[Path] = []
    with locked(path):  # another process is training it
        waiter = threading.Thread(
            target=lambda: done.append(cached_file(path, lambda p: built.append("again") or p,
                                                   _check)))
        waiter.start()
        path.write_bytes(GOOD)  # ... and saves it
    waiter.join(60)
    assert done == [path] and built == []


def test_an_unusable_file_is_trained_again(tmp_path: Path, caplog: pytest.LogCaptureFixture
                                           ) -> None:
    path = tmp_path / "model.npz"
    path.write_bytes(b"half a file")

    def build(p: Path) -> Path:
        p.write_bytes(GOOD)
        return p

    assert cached_file(path, build, _check) == path and path.read_bytes() == GOOD
    assert "retraining: cached model unusable" in caplog.text
