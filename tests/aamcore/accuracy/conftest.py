"""The accuracy tests' shared parts: the small test model loaded once, and the held-out
slice of real faces it never trained on."""

from __future__ import annotations

from pathlib import Path

import pytest

from aamcore.fitting.model import FittingModel
from aamcore.io import FaceSample
from tests.aamcore.accuracy.held_out import slice_of


@pytest.fixture(scope="session")
def small_model(model_path: Path) -> FittingModel:
    return FittingModel.load(model_path)


@pytest.fixture(scope="session")
def held_out_slice(data_dir: Path, small_model: FittingModel) -> list[FaceSample]:
    """:data:`~tests.aamcore.accuracy.held_out.PER_SET` held-out faces of each of LFPW, HELEN
    and AFW."""
    return slice_of(data_dir, small_model.aam)
