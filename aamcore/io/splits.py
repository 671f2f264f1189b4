"""The project's held-out split of the in-the-wild 68-point sets.

Every tool that trains or measures on ``lfpw``, ``helen`` or ``afw`` uses this
split, so that numbers agree across the project. Faces are grouped by the
photo they come from (HELEN and AFW crop several faces from one photo, named
``<photo>_<k>``); a group is held out iff the first byte of
``sha1(f"{set}/{group}")`` is divisible by 5 (about 20 % of the photos).
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Sequence
from pathlib import Path

from aamcore.io.sample import FaceSample

SPLIT_SETS: tuple[str, ...] = ("lfpw", "helen", "afw")
"""Sets the split is defined for."""

_FACE_INDEX = re.compile(r"_\d+$")


def group_key(stem: str, set_name: str) -> str:
    """The photo a face comes from: the file stem, less ``_<digits>`` for HELEN and AFW.

    Raises
    ------
    ValueError
        For a set the split is not defined for.
    """
    if set_name not in SPLIT_SETS:
        raise ValueError(f"no split for set {set_name!r}: choose one of {SPLIT_SETS}")
    if set_name == "lfpw":
        return stem
    return _FACE_INDEX.sub("", stem)


def is_held_out(stem: str, set_name: str) -> bool:
    """Whether the face of file stem ``stem`` in ``set_name`` is in the held-out part."""
    key = f"{set_name}/{group_key(stem, set_name)}".encode()
    return hashlib.sha1(key).digest()[0] % 5 == 0


def split(
    samples: Sequence[FaceSample], set_name: str
) -> tuple[list[FaceSample], list[FaceSample]]:
    """Split ``samples`` of one set into ``(train, test)``, keeping their order."""
    train: list[FaceSample] = []
    test: list[FaceSample] = []
    for sample in samples:
        (test if is_held_out(Path(sample.image_path).stem, set_name) else train).append(sample)
    return train, test


def set_name_of(path: str | Path) -> str:
    """Which split set a dataset folder holds, from its path (``.../helen/trainset``).

    Raises
    ------
    ValueError
        If no part of the path names one of :data:`SPLIT_SETS`.
    """
    for part in reversed(Path(path).parts):
        if part.lower() in SPLIT_SETS:
            return part.lower()
    raise ValueError(f"{path}: not a folder of one of {SPLIT_SETS}")
