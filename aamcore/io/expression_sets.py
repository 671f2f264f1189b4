"""The expression sets of real faces besides JAFFE, and the held-out split of each, by person.

- ``taiwan_expressions``: 884 frontal posed faces of 21 performers; the file name
  ``0111b01.jpg`` is performer ``01``, elicitation ``1``, view ``1``, class letter ``b``
  (a-g: NE, HA, SA, AN, DI, FE, SU), serial ``01``.
- ``lfw_expressions``: 3,921 in-the-wild faces of 2,097 people, crowd labels in
  ``labels.csv`` (``image,person,expression,width,height``, JAFFE's class codes).

Each set has a fixed held-out part, split by person (never one person on both sides):
:data:`TAIWAN_HELD_OUT` (8 of the 21 performers) and, for ``lfw_expressions``, the
people whose ``sha1("lfw_expressions/<person>")`` has a first byte divisible by 5
(about 20 %). Benchmarks score those people and nothing trains on them.

Every sample is an :class:`~aamcore.io.jaffe.ExpressionSample` whose ``poser`` is the
person; a file the set names that is missing, or an image that cannot be decoded, is a
:class:`~aamcore.io.sample.DatasetError` naming it.
"""

from __future__ import annotations

import csv
import hashlib
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aamcore.config import data_root
from aamcore.io.jaffe import JAFFE_CLASSES, ExpressionSample, load_jaffe
from aamcore.io.sample import DatasetError

EXPRESSION_SETS: tuple[str, ...] = ("jaffe", "taiwan_expressions", "lfw_expressions")
"""The labelled expression sets under the data root."""
TAIWAN_LETTERS: dict[str, str] = {"a": "NE", "b": "HA", "c": "SA", "d": "AN", "e": "DI",
                                  "f": "FE", "g": "SU"}
"""The Taiwanese set's class letters as JAFFE's codes."""
TAIWAN_HELD_OUT: tuple[str, ...] = ("01", "14", "16", "17", "18", "20", "25", "29")
"""The Taiwanese performers held out: 8 of 21, the first 8 by the SHA-1 of
``taiwan_expressions/<performer>``."""
LFW_HELD_OUT_MODULUS = 5
"""A person of ``lfw_expressions`` is held out iff the first byte of the SHA-1 of
``lfw_expressions/<person>`` is divisible by this."""
_TAIWAN_NAME = re.compile(r"^(?P<person>\d{2})(?P<take>\d)(?P<view>\d)(?P<letter>[a-g])"
                          r"(?P<serial>\d+)$")


@dataclass
class ExpressionSet:
    """The labelled faces of one expression set.

    Attributes
    ----------
    name : str
        One of :data:`EXPRESSION_SETS`.
    samples : list of ExpressionSample
        In a fixed order (file name, or the order of ``labels.csv``).
    root : Path
    """

    name: str
    samples: list[ExpressionSample]
    root: Path

    def labels(self) -> np.ndarray:
        """Class code of each sample, shape (n,)."""
        return np.array([s.label for s in self.samples])

    def persons(self) -> np.ndarray:
        """Person of each sample, shape (n,)."""
        return np.array([s.poser for s in self.samples])

    def held_out(self) -> np.ndarray:
        """Whether each sample (n,) is in the set's held-out part (JAFFE has none)."""
        return np.array([is_held_out(self.name, s.poser) for s in self.samples], dtype=bool)


def is_held_out(set_name: str, person: str) -> bool:
    """Whether ``person`` of ``set_name`` is held out (module docstring)."""
    if set_name == "taiwan_expressions":
        return person in TAIWAN_HELD_OUT
    if set_name == "lfw_expressions":
        digest = hashlib.sha1(f"lfw_expressions/{person}".encode()).digest()
        return digest[0] % LFW_HELD_OUT_MODULUS == 0
    return False


def parse_taiwan_name(path: str | Path) -> ExpressionSample:
    """Person, class, elicitation and serial from a Taiwanese file name.

    Raises
    ------
    DatasetError
        Naming the file when the name does not follow the pattern.
    """
    path = Path(path)
    match = _TAIWAN_NAME.match(path.stem)
    if match is None:
        raise DatasetError(f"{path}: name does not follow the Taiwanese set's pattern "
                           "PPEVLSS.jpg (for example 0111b01.jpg)")
    return ExpressionSample(path, match["person"], TAIWAN_LETTERS[match["letter"]],
                            int(match["take"]), int(match["serial"]))


def load_taiwan(folder: str | Path | None = None) -> ExpressionSet:
    """Every ``.jpg`` of the Taiwanese set's folder, by file name.

    Raises
    ------
    DatasetError
        When the folder is missing, holds no image or a name does not parse.
    """
    root = _folder(folder, "taiwan_expressions")
    samples = [parse_taiwan_name(p) for p in sorted(root.glob("*.jpg"))]
    if not samples:
        raise DatasetError(f"{root}: no Taiwanese expression image (*.jpg)")
    return ExpressionSet("taiwan_expressions", samples, root)


def load_lfw_expressions(folder: str | Path | None = None) -> ExpressionSet:
    """The faces ``labels.csv`` lists, with their person and crowd label.

    Raises
    ------
    DatasetError
        When the folder or ``labels.csv`` is missing or malformed, a label is not a
        class code, or a listed image file is missing (named).
    """
    root = _folder(folder, "lfw_expressions")
    table = root / "labels.csv"
    if not table.is_file():
        raise DatasetError(f"{table}: label file not found")
    samples = []
    with table.open(newline="") as f:
        for line, row in enumerate(csv.DictReader(f), start=2):
            try:
                image, person, label = row["image"], row["person"], row["expression"]
            except KeyError as exc:
                raise DatasetError(f"{table}: line {line} lacks the column {exc}") from exc
            if label not in JAFFE_CLASSES:
                raise DatasetError(f"{table}: line {line}: unknown class {label!r}")
            path = root / "images" / image
            if not path.is_file():
                raise DatasetError(f"{path}: image file not found (listed in {table}, line "
                                   f"{line})")
            samples.append(ExpressionSample(path, person, label, 0, line - 2))
    if not samples:
        raise DatasetError(f"{table}: no face listed")
    return ExpressionSet("lfw_expressions", samples, root)


def load_expression_set(name: str, folder: str | Path | None = None) -> ExpressionSet:
    """The set called ``name`` (one of :data:`EXPRESSION_SETS`), from ``folder`` or the data
    root.

    Raises
    ------
    DatasetError
        As its reader; ValueError for an unknown name.
    """
    if name == "jaffe":
        jaffe = load_jaffe(folder)
        if jaffe.errors:
            raise DatasetError(f"{jaffe.root}: unreadable JAFFE files: "
                               + "; ".join(jaffe.errors[:3]))
        return ExpressionSet("jaffe", jaffe.samples, jaffe.root)
    if name == "taiwan_expressions":
        return load_taiwan(folder)
    if name == "lfw_expressions":
        return load_lfw_expressions(folder)
    raise ValueError(f"unknown expression set {name!r}: choose one of {EXPRESSION_SETS}")


def _folder(folder: str | Path | None, name: str) -> Path:
    root = Path(folder) if folder is not None else data_root() / name
    if not root.is_dir():
        raise DatasetError(f"{root}: {name} folder not found")
    return root
