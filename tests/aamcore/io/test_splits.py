"""The project's held-out split of LFPW, HELEN and AFW."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest

from aamcore.io import FaceSample
from aamcore.io.splits import group_key, is_held_out, set_name_of, split


def _samples(stems: list[str]) -> list[FaceSample]:
    return [FaceSample(Path(f"/nowhere/{s}.jpg"), np.zeros((68, 2))) for s in stems]


def test_group_key_drops_the_face_index_for_helen_and_afw_only() -> None:
    assert group_key("100040721_2", "helen") == "100040721"
    assert group_key("1051618982_1", "afw") == "1051618982"
    assert group_key("image_0001", "lfpw") == "image_0001"
    with pytest.raises(ValueError, match="no split"):
        group_key("x", "ibug")


def test_rule_is_the_first_sha1_byte_mod_5() -> None:
    for stem in ("image_0001", "image_0002", "image_0417"):
        expected = hashlib.sha1(f"lfpw/{stem}".encode()).digest()[0] % 5 == 0
        assert is_held_out(stem, "lfpw") == expected


def test_faces_of_one_photo_fall_on_one_side() -> None:
    stems = [f"{photo}_{k}" for photo in range(1000, 1400) for k in (1, 2, 3)]
    train, test = split(_samples(stems), "helen")
    side = {}
    for part, samples in (("train", train), ("test", test)):
        for s in samples:
            photo = s.image_path.stem.rsplit("_", 1)[0]
            assert side.setdefault(photo, part) == part
    assert len(train) + len(test) == len(stems)
    assert 0.12 < len(test) / len(stems) < 0.28  # about one photo in five


def test_split_keeps_order_and_sets_differ() -> None:
    stems = [f"image_{k:04d}" for k in range(1, 300)]
    train, test = split(_samples(stems), "lfpw")
    order = {s: k for k, s in enumerate(stems)}
    for part in (train, test):
        keys = [order[s.image_path.stem] for s in part]
        assert keys == sorted(keys)
    _, test_afw = split(_samples(stems), "afw")  # same names, another set: another draw
    assert {s.image_path.stem for s in test} != {s.image_path.stem for s in test_afw}


def test_set_name_of_reads_the_folder() -> None:
    assert set_name_of("/data/helen/trainset") == "helen"
    assert set_name_of(Path("/data/lfpw/trainset")) == "lfpw"
    with pytest.raises(ValueError):
        set_name_of("/data/jaffe")
