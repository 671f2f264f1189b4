"""Shared fixtures: the data root and paths to the real datasets."""

from __future__ import annotations

from pathlib import Path

import pytest

from aamcore.config import data_root


@pytest.fixture(scope="session")
def data_dir() -> Path:
    root = data_root()
    if not root.is_dir():
        pytest.fail(f"data root {root} not found: set AAMTRACK_DATA")
    return root


@pytest.fixture(scope="session")
def imm_dir(data_dir: Path) -> Path:
    return data_dir / "imm_frontal"


@pytest.fixture(scope="session")
def lfpw_dir(data_dir: Path) -> Path:
    return data_dir / "lfpw" / "trainset"
