"""The held-out slice: fixed, unseen by the test model, and a missing folder a failure that
names it (CI always has the data: a skip would hide a broken data folder)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from aamcore.fitting.model import FittingModel
from aamcore.io import FaceSample
from aamcore.io.splits import is_held_out, set_name_of
from tests.aamcore.accuracy.held_out import FOLDERS, PER_SET, held_out_faces

pytestmark = pytest.mark.accuracy


def test_the_slice_is_the_held_out_split_of_every_set(held_out_slice: list[FaceSample],
                                                      small_model: FittingModel) -> None:
    names = [set_name_of(f.image_path.parent) for f in held_out_slice]
    assert [names.count(n) for n in FOLDERS] == [PER_SET] * len(FOLDERS)
    assert all(is_held_out(f.image_path.stem, n) for f, n in zip(held_out_slice, names,
                                                                 strict=True))
    trained = set(small_model.aam.summary["fit_images"])  # every face the model learned from
    assert trained and not trained & {f.image_id() for f in held_out_slice}


def test_a_missing_or_short_folder_fails_naming_it(tmp_path: Path, data_dir: Path) -> None:
    with pytest.raises(pytest.fail.Exception, match=str(tmp_path / "afw")):
        held_out_faces(tmp_path, "afw")
    few = tmp_path / "afw"
    few.mkdir()
    for image in sorted((data_dir / "afw").glob("*.jpg"))[:3]:
        shutil.copy(image, few)
        shutil.copy(image.with_suffix(".pts"), few)
    with pytest.raises(pytest.fail.Exception, match=f"{few}: .* held-out faces of afw"):
        held_out_faces(tmp_path, "afw")
