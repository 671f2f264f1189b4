"""Load every annotated image of a folder."""

from __future__ import annotations

import re
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from aamcore.io.asf import read_asf
from aamcore.io.landmarks import LandmarkScheme, imm_scheme, scheme_for
from aamcore.io.pts import read_pts
from aamcore.io.sample import DatasetError, FaceSample

IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff")
_IMM_NAME = re.compile(r"^(\d+)_\d+$")


@dataclass
class AnnotatedSet:
    """The readable samples of a folder and what could not be read.

    Attributes
    ----------
    samples : list of FaceSample
        Samples sorted by file name.
    scheme : LandmarkScheme
        Markup of the samples.
    errors : list of str
        One message per skipped file, naming it and the problem.
    root : Path
        The folder.
    """

    samples: list[FaceSample]
    scheme: LandmarkScheme
    root: Path
    errors: list[str] = field(default_factory=list)

    def subjects(self) -> list[str]:
        """Distinct subject ids, sorted (empty if the names give none)."""
        return sorted({s.subject for s in self.samples if s.subject is not None})


def _subject_from_name(stem: str) -> str | None:
    match = _IMM_NAME.match(stem)
    return match.group(1) if match else None


def _image_for(annotation: Path) -> Path:
    for suffix in IMAGE_SUFFIXES:
        candidate = annotation.with_suffix(suffix)
        if candidate.is_file():
            return candidate
    raise DatasetError(f"{annotation}: no image file beside it ({', '.join(IMAGE_SUFFIXES)})")


def _image_size(path: Path) -> tuple[int, int]:
    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if image is None:
        raise DatasetError(f"{path}: not a readable image")
    return image.shape[1], image.shape[0]


def _read_annotation(path: Path) -> tuple[FaceSample, tuple[np.ndarray, np.ndarray] | None]:
    """One ``.asf`` or ``.pts`` annotation as a sample.

    Returns
    -------
    sample : FaceSample
    topology : tuple of arrays or None
        The ``(paths, connects_to)`` of an ``.asf`` markup; None for ``.pts``.

    Raises
    ------
    DatasetError
        If the annotation or its image cannot be read.
    """
    topology = None
    if path.suffix == ".asf":
        shape = read_asf(path)
        image_path = path.parent / shape.image_name
        if not image_path.is_file():
            image_path = _image_for(path)
        points = shape.pixels(*_image_size(image_path))
        topology = (shape.paths, shape.connects_to)
    else:
        points = read_pts(path)
        image_path = _image_for(path)
    return FaceSample(image_path, points, _subject_from_name(path.stem)), topology


def _unannotated(root: Path, samples: list[FaceSample], files: list[Path]) -> list[str]:
    """One message per image of ``root`` that no annotation file names: an image whose
    annotation is missing is named, not silently left out."""
    used = {s.image_path.name for s in samples} | {p.stem for p in files}
    return [f"{image}: no .pts or .asf annotation beside it" for image in sorted(root.iterdir())
            if image.suffix.lower() in IMAGE_SUFFIXES
            and image.name not in used and image.stem not in used]


def load_annotated_folder(folder: str | Path, limit: int | None = None) -> AnnotatedSet:
    """Read every ``.asf`` or ``.pts`` annotation of ``folder`` with its image.

    Files that cannot be read, or whose point count differs from the most
    common one, are skipped and listed in ``errors``, as are images without an
    annotation (when the whole folder is read).

    Parameters
    ----------
    folder : path
        Folder holding annotation files beside their images.
    limit : int, optional
        Read at most this many annotations (in file-name order).

    Raises
    ------
    DatasetError
        If the folder is missing or has no readable annotated image.
    """
    root = Path(folder)
    if not root.is_dir():
        raise DatasetError(f"{root}: dataset folder not found")
    files = sorted(list(root.glob("*.asf")) + list(root.glob("*.pts")))
    if limit is not None:
        files = files[:limit]
    if not files:
        raise DatasetError(f"{root}: no .asf or .pts annotation files")

    samples: list[FaceSample] = []
    errors: list[str] = []
    topology: tuple[np.ndarray, np.ndarray] | None = None
    for path in files:
        try:
            sample, paths = _read_annotation(path)
        except DatasetError as exc:
            errors.append(str(exc))
            continue
        samples.append(sample)
        if topology is None:
            topology = paths

    if not samples:
        raise DatasetError(f"{root}: no readable annotated image ({len(errors)} files failed)")
    if limit is None:
        errors += _unannotated(root, samples, files)
    n_points = Counter(len(s.points) for s in samples).most_common(1)[0][0]
    kept = []
    for s in samples:
        if len(s.points) == n_points:
            kept.append(s)
        else:
            errors.append(f"{s.image_path}: {len(s.points)} points, the others have {n_points}")
    if topology is not None and len(topology[0]) == n_points:
        scheme = imm_scheme(*topology)
    else:
        scheme = scheme_for(n_points)
    return AnnotatedSet(kept, scheme, root, errors)
