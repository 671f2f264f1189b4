"""The JAFFE facial expression database (Lyons et al. 1998).

213 grey 256x256 TIFF images of 10 Japanese female posers. The file name
carries the labels: ``KA.HA1.29.tiff`` is poser ``KA``, class ``HA``
(happiness), take 1, running index 29.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from aamcore.config import data_root
from aamcore.io.sample import DatasetError, read_image

JAFFE_CLASSES: dict[str, str] = {
    "NE": "neutral",
    "HA": "happiness",
    "SA": "sadness",
    "SU": "surprise",
    "AN": "anger",
    "FE": "fear",
    "DI": "disgust",
}
"""Class codes in the order of the thesis tables, with their meaning."""

JAFFE_SUFFIXES = (".tiff", ".tif")
_NAME = re.compile(r"^(?P<poser>[A-Z]{2})\.(?P<label>[A-Z]{2})(?P<take>\d+)\.(?P<index>\d+)$")


@dataclass(frozen=True)
class ExpressionSample:
    """One labelled expression image.

    Attributes
    ----------
    image_path : Path
        The image file.
    poser : str
        Poser id (``KA``).
    label : str
        Class code, a key of :data:`JAFFE_CLASSES` (``HA``).
    take : int
        Take number of this poser and class.
    index : int
        Running index of the image in the database.
    """

    image_path: Path
    poser: str
    label: str
    take: int
    index: int

    def load_image(self) -> np.ndarray:
        """Read the image as uint8 grey, shape (H, W)."""
        return read_image(self.image_path, grey=True)


@dataclass
class JaffeSet:
    """The readable JAFFE samples of a folder and what could not be read.

    Attributes
    ----------
    samples : list of ExpressionSample
        Samples sorted by file name.
    root : Path
        The folder.
    errors : list of str
        One message per skipped file, naming it and the problem.
    """

    samples: list[ExpressionSample]
    root: Path
    errors: list[str] = field(default_factory=list)

    def labels(self) -> np.ndarray:
        """Class code of each sample, shape (n,)."""
        return np.array([s.label for s in self.samples])

    def posers(self) -> np.ndarray:
        """Poser id of each sample, shape (n,)."""
        return np.array([s.poser for s in self.samples])


def parse_jaffe_name(path: str | Path) -> ExpressionSample:
    """Read poser, class, take and index from a JAFFE file name.

    Raises
    ------
    DatasetError
        Naming the file, if the name is not ``PP.CCt.i.tiff`` or the class
        code is not one of :data:`JAFFE_CLASSES`.
    """
    path = Path(path)
    if path.suffix.lower() not in JAFFE_SUFFIXES:
        raise DatasetError(f"{path}: not a JAFFE image (expected suffix .tiff or .tif)")
    match = _NAME.match(path.stem)
    if match is None:
        raise DatasetError(
            f"{path}: name does not follow the JAFFE pattern POSER.CLASSTAKE.INDEX.tiff "
            "(for example KA.HA1.29.tiff)"
        )
    label = match["label"]
    if label not in JAFFE_CLASSES:
        raise DatasetError(
            f"{path}: unknown expression class {label!r} (expected one of "
            f"{', '.join(JAFFE_CLASSES)})"
        )
    return ExpressionSample(path, match["poser"], label, int(match["take"]), int(match["index"]))


def default_jaffe_folder() -> Path:
    """The JAFFE folder under the data root."""
    return data_root() / "jaffe"


def load_jaffe(folder: str | Path | None = None) -> JaffeSet:
    """Read every JAFFE image of a folder.

    Files whose name does not parse, or which cannot be decoded as an image,
    are skipped and listed in ``errors``. Files with other suffixes are
    ignored.

    Parameters
    ----------
    folder : path, optional
        The folder; by default ``<data root>/jaffe``.

    Raises
    ------
    DatasetError
        If the folder is missing or holds no readable JAFFE image.
    """
    root = Path(folder) if folder is not None else default_jaffe_folder()
    if not root.is_dir():
        raise DatasetError(f"{root}: JAFFE folder not found")
    files = sorted(p for p in root.iterdir() if p.suffix.lower() in JAFFE_SUFFIXES)
    samples: list[ExpressionSample] = []
    errors: list[str] = []
    for path in files:
        try:
            sample = parse_jaffe_name(path)
            sample.load_image()
        except DatasetError as exc:
            errors.append(str(exc))
            continue
        samples.append(sample)
    if not samples:
        raise DatasetError(f"{root}: no readable JAFFE image ({len(errors)} files failed)")
    return JaffeSet(samples, root, errors)
