"""One annotated face and the error raised for unreadable files."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np


class DatasetError(ValueError):
    """A dataset file is missing, unreadable or inconsistent; the message names it."""


@dataclass(frozen=True)
class FaceSample:
    """An image file with its landmarks.

    Attributes
    ----------
    image_path : Path
        The image file.
    points : (N, 2) float64 array
        Landmarks in 0-based pixel coordinates, ``(x, y)``.
    subject : str or None
        Subject identifier when the file name gives one (IMM: ``01_03`` is
        subject ``01``), else None.
    """

    image_path: Path
    points: np.ndarray
    subject: str | None = None

    def load_image(self) -> np.ndarray:
        """Read the image as uint8 BGR, shape (H, W, 3)."""
        return read_image(self.image_path)

    def image_id(self) -> str:
        """The image's identity: a digest of its file's bytes (16 hex digits).

        Unlike the file name it tells apart ``lfpw/trainset/image_0001.png``
        and ``lfpw/testset/image_0001.png``, and it survives a moved data folder.
        """
        return image_digest(self.image_path)


def image_digest(path: str | Path) -> str:
    """SHA-1 of a file's bytes, its first 16 hex digits (an unreadable file: its resolved path)."""
    try:
        return hashlib.sha1(Path(path).read_bytes()).hexdigest()[:16]
    except OSError:
        return str(Path(path).resolve())


def read_image(path: str | Path, grey: bool = False) -> np.ndarray:
    """Read an image file as uint8, BGR (H, W, 3) or grey (H, W).

    Raises
    ------
    DatasetError
        If the file is missing or cannot be decoded.
    """
    path = Path(path)
    if not path.is_file():
        raise DatasetError(f"{path}: image file not found")
    flag = cv2.IMREAD_GRAYSCALE if grey else cv2.IMREAD_COLOR
    image = cv2.imread(str(path), flag)
    if image is None:
        raise DatasetError(f"{path}: not a readable image")
    return image
