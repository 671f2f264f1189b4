"""The fixed held-out slice of real faces the accuracy tests measure on.

The project's split (:mod:`aamcore.io.splits`) holds out a fifth of the photos of LFPW,
HELEN and AFW, chosen by a hash of the photo's name: no model of the recipe trains on them.
The slice is :data:`PER_SET` of each set's held-out faces, spread evenly over them, in the
set's order, so that every run measures the same faces. A face the model trained on all the
same (the same image under another name) is refused by :func:`slice_of`, not skipped.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from aamcore.evaluation.fits import held_out
from aamcore.io import FaceSample, load_annotated_folder
from aamcore.io.sample import DatasetError
from aamcore.io.splits import split
from aamcore.model.aam import AAM

FOLDERS = {"lfpw": "lfpw/trainset", "helen": "helen/trainset", "afw": "afw"}
"""Each set's folder under the data root."""
PER_SET = 20
"""Held-out faces of each set in the slice."""


def spread(items: list, count: int) -> list:
    """``count`` of ``items`` evenly spread over them, in order."""
    if len(items) <= count:
        return list(items)
    return [items[k * len(items) // count] for k in range(count)]


def held_out_faces(data_dir: Path, set_name: str, count: int = PER_SET) -> list[FaceSample]:
    """``count`` held-out faces of ``set_name``; the test fails, naming the folder, when the
    folder is missing or holds fewer."""
    folder = data_dir / FOLDERS[set_name]
    try:
        data = load_annotated_folder(folder)
    except DatasetError as exc:
        pytest.fail(f"the held-out faces of {set_name} are read from {folder}: {exc}")
    _, test = split(data.samples, set_name)
    if len(test) < count:
        pytest.fail(f"{folder}: {len(test)} held-out faces of {set_name}, the accuracy tests "
                    f"measure {count}: is the data folder complete?")
    return spread(test, count)


def slice_of(data_dir: Path, aam: AAM, per_set: int = PER_SET) -> list[FaceSample]:
    """The held-out slice of every set, checked against what ``aam``'s model trained on."""
    faces = [f for name in FOLDERS for f in held_out_faces(data_dir, name, per_set)]
    unseen = held_out(aam, faces)
    assert len(unseen) == len(faces), (
        "faces of the held-out split are in the model's training set: "
        f"{sorted({f.image_path.name for f in faces} - {f.image_path.name for f in unseen})}")
    return faces

