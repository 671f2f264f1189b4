"""aamcore.io.expression_sets: the Taiwanese and LFW expression sets, their held-out split by
person, and files that are missing or misnamed."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from aamcore.expression.labels import SEVEN_CLASSES
from aamcore.io.expression_sets import (
    TAIWAN_HELD_OUT,
    load_expression_set,
    load_lfw_expressions,
    load_taiwan,
    parse_taiwan_name,
)
from aamcore.io.sample import DatasetError


def test_the_taiwanese_set_is_read_and_split_by_performer(data_dir: Path) -> None:
    data = load_taiwan(data_dir / "taiwan_expressions")
    labels, persons, held = data.labels(), data.persons(), data.held_out()
    assert len(data.samples) == 884 and set(labels) == set(SEVEN_CLASSES)
    assert len(set(persons)) == 21 and set(persons[held]) == set(TAIWAN_HELD_OUT)
    assert not set(persons[held]) & set(persons[~held])
    sample = parse_taiwan_name("0111b01.jpg")
    assert (sample.poser, sample.label, sample.take, sample.index) == ("01", "HA", 1, 1)


def test_the_lfw_set_is_read_and_split_by_person(data_dir: Path) -> None:
    data = load_lfw_expressions(data_dir / "lfw_expressions")
    persons, held = data.persons(), data.held_out()
    assert len(data.samples) == 3921 and len(set(persons)) == 2097
    assert not set(persons[held]) & set(persons[~held])  # never one person on both sides
    assert 0.15 < held.mean() < 0.25
    assert set(data.labels()[held]) == set(SEVEN_CLASSES)
    assert not load_expression_set("jaffe", data_dir / "jaffe").held_out().any()


def test_a_listed_image_that_is_missing_is_named(tmp_path: Path, data_dir: Path) -> None:
    source = data_dir / "lfw_expressions"
    (tmp_path / "images").mkdir()
    rows = (source / "labels.csv").read_text().splitlines()[:4]
    for row in rows[1:3]:
        name = row.split(",")[0]
        shutil.copy(source / "images" / name, tmp_path / "images" / name)
    (tmp_path / "labels.csv").write_text("\n".join(rows) + "\n")
    missing = rows[3].split(",")[0]
    with pytest.raises(DatasetError, match=f"{missing}: image file not found.*line 4"):
        load_lfw_expressions(tmp_path)
    (tmp_path / "labels.csv").write_text("\n".join(rows[:3]) + "\n")
    assert len(load_lfw_expressions(tmp_path).samples) == 2
    image, person, _, *size = rows[1].split(",")
    (tmp_path / "labels.csv").write_text(rows[0] + "\n" + ",".join([image, person, "XX", *size])
                                         + "\n")
    with pytest.raises(DatasetError, match="line 2: unknown class 'XX'"):
        load_lfw_expressions(tmp_path)


def test_missing_folders_and_misnamed_files_are_named(tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match="taiwan_expressions folder not found"):
        load_taiwan(tmp_path / "nowhere")
    with pytest.raises(DatasetError, match="no Taiwanese expression image"):
        load_taiwan(tmp_path)
    (tmp_path / "portrait.jpg").write_bytes(b"")
    with pytest.raises(DatasetError, match="portrait.jpg: name does not follow"):
        load_taiwan(tmp_path)
    with pytest.raises(DatasetError, match="labels.csv: label file not found"):
        load_lfw_expressions(tmp_path)
    with pytest.raises(ValueError, match="unknown expression set"):
        load_expression_set("ck+")
