"""The JAFFE reader on the real folder and on bad files."""

from __future__ import annotations

import shutil
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from aamcore.io.jaffe import JAFFE_CLASSES, JaffeSet, load_jaffe, parse_jaffe_name
from aamcore.io.sample import DatasetError


def test_real_folder_has_213_images_of_10_posers_and_7_classes(jaffe_set: JaffeSet) -> None:
    assert jaffe_set.errors == []
    assert len(jaffe_set.samples) == 213
    assert len(set(jaffe_set.posers())) == 10
    counts = Counter(jaffe_set.labels().tolist())
    assert set(counts) == set(JAFFE_CLASSES)
    assert all(29 <= n <= 33 for n in counts.values()), counts


def test_sample_fields_follow_the_file_name(jaffe_set: JaffeSet) -> None:
    sample = next(s for s in jaffe_set.samples if s.image_path.name == "KA.HA1.29.tiff")
    assert (sample.poser, sample.label, sample.take, sample.index) == ("KA", "HA", 1, 29)
    image = sample.load_image()
    assert image.shape == (256, 256) and image.dtype == np.uint8


@pytest.mark.parametrize(
    "name",
    ["KA.XX1.29.tiff", "KAHA1.29.tiff", "ka.HA1.29.tiff", "KA.HA.29.tiff", "KA.HA1.tiff"],
)
def test_bad_names_are_refused_with_the_file_named(name: str) -> None:
    with pytest.raises(DatasetError, match=name.replace(".", r"\.")):
        parse_jaffe_name(name)


def test_bad_files_are_skipped_and_reported(jaffe_dir: Path, tmp_path: Path) -> None:
    for name in ("KA.HA1.29.tiff", "KL.SU2.165.tiff"):
        shutil.copy(jaffe_dir / name, tmp_path / name)
    (tmp_path / "KA.ZZ1.30.tiff").write_bytes((jaffe_dir / "KA.HA1.29.tiff").read_bytes())
    (tmp_path / "KA.SA1.33.tiff").write_bytes(b"not a tiff")
    (tmp_path / "README.txt").write_text("ignored: not an image suffix")

    loaded = load_jaffe(tmp_path)

    assert [s.image_path.name for s in loaded.samples] == ["KA.HA1.29.tiff", "KL.SU2.165.tiff"]
    assert len(loaded.errors) == 2
    assert any("KA.ZZ1.30.tiff" in e and "unknown expression class" in e for e in loaded.errors)
    assert any("KA.SA1.33.tiff" in e and "not a readable image" in e for e in loaded.errors)


def test_missing_or_empty_folder_raises(tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match="not found"):
        load_jaffe(tmp_path / "nowhere")
    (tmp_path / "XX.HA1.1.tiff").write_bytes(b"broken")
    with pytest.raises(DatasetError, match="no readable JAFFE image"):
        load_jaffe(tmp_path)
