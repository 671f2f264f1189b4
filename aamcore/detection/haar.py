"""Face detection with OpenCV's Haar cascades (Viola-Jones, thesis section 7.2.1).

The detector gives the rough face location that starts an AAM search; see
:mod:`aamcore.detection.mapping` for turning its box into a start shape.
Detection is the costliest stage of a tracker: run it to acquire or re-acquire
a face, not on every tracked frame.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from aamcore import defaults

DEFAULT_CASCADE = "haarcascade_frontalface_alt2.xml"
"""Cascade file used by default, from ``cv2.data.haarcascades``."""

_INSTALL_HINT = (
    "OpenCV 5 ships no Haar cascades and no CascadeClassifier: "
    "install opencv-python-headless<5 (e.g. pip install 'opencv-python-headless>=4.10,<5')"
)


def cascade_path(name: str | Path = DEFAULT_CASCADE) -> Path:
    """Resolve a cascade file name or path.

    Parameters
    ----------
    name : str or Path
        A file name under ``cv2.data.haarcascades`` (e.g.
        ``"haarcascade_frontalface_default.xml"``) or a path to an XML file.

    Raises
    ------
    FileNotFoundError
        If the file does not exist; for a bare name, the message says how to
        get an OpenCV that ships the cascades.
    """
    path = Path(name)
    if path.is_file():
        return path
    folder = getattr(getattr(cv2, "data", None), "haarcascades", None)
    bare_name = path.name == str(name)
    if folder is not None and bare_name and (Path(folder) / path.name).is_file():
        return Path(folder) / path.name
    where = f"under cv2.data.haarcascades ({folder})" if folder else "(cv2.data is missing)"
    raise FileNotFoundError(
        f"Haar cascade {str(name)!r} not found {where}, nor as a file path. {_INSTALL_HINT}"
    )


def _check_image(image: object) -> np.ndarray:
    if image is None:
        raise ValueError("image is None (a failed cv2.imread or an empty frame?)")
    if not isinstance(image, np.ndarray):
        raise ValueError(f"image must be a numpy array, got {type(image).__name__}")
    if image.size == 0:
        raise ValueError(f"image is empty, shape {image.shape}")
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[:, :, 0]
    if not (image.ndim == 2 or (image.ndim == 3 and image.shape[2] in (3, 4))):
        raise ValueError(
            f"image shape {image.shape} is not (H, W) grey, (H, W, 3) BGR or (H, W, 4) BGRA"
        )
    if image.dtype == np.bool_ or not (
        image.dtype in (np.uint8, np.uint16) or np.issubdtype(image.dtype, np.floating)
    ):
        raise ValueError(f"image dtype {image.dtype} is not uint8, uint16 or floating point")
    if np.issubdtype(image.dtype, np.floating) and not np.all(np.isfinite(image)):
        raise ValueError("image holds NaN or infinite values")
    return image


def _stretch_to_uint8(grey: np.ndarray) -> np.ndarray:
    """Map the value range of a 16-bit or float grey image linearly onto 0..255.

    Stretching the image's own range (rather than dividing by 257) keeps the
    precision of 10- and 12-bit data stored in 16-bit containers; Haar
    features are normalised by each window's variance, so the linear change
    of contrast does not change what the cascade finds.
    """
    grey = grey.astype(np.float32)
    lo, hi = float(grey.min()), float(grey.max())
    if hi <= lo:
        return np.zeros(grey.shape, np.uint8)
    return np.clip((grey - lo) * (255.0 / (hi - lo)) + 0.5, 0, 255).astype(np.uint8)


def to_grey_uint8(image: np.ndarray) -> np.ndarray:
    """Convert a frame to the 8-bit grey image the cascade needs.

    Parameters
    ----------
    image : (H, W), (H, W, 1), (H, W, 3) BGR or (H, W, 4) BGRA array
        uint8, uint16 or float. 16-bit and float images are stretched
        linearly from their own min..max onto 0..255.

    Returns
    -------
    (H, W) uint8 array

    Raises
    ------
    ValueError
        For None, a non-array, an empty image, an unsupported shape or dtype,
        or a float image holding NaN or infinity.
    """
    image = _check_image(image)
    if np.issubdtype(image.dtype, np.floating) and image.dtype != np.float32:
        image = image.astype(np.float32)  # cvtColor takes 8U, 16U and 32F only
    if image.ndim == 3:
        code = cv2.COLOR_BGR2GRAY if image.shape[2] == 3 else cv2.COLOR_BGRA2GRAY
        image = cv2.cvtColor(np.ascontiguousarray(image), code)
    if image.dtype == np.uint8:
        return image
    return _stretch_to_uint8(image)


class HaarFaceDetector:
    """Frontal face detector around :class:`cv2.CascadeClassifier`.

    Parameters
    ----------
    cascade : str or Path
        Cascade file name under ``cv2.data.haarcascades`` or a path.
    scale_factor : float
        Step between detection scales (> 1; larger is faster and coarser).
    min_neighbors : int
        Overlapping raw detections needed to keep a box (>= 0).
    min_size : (int, int)
        Smallest face (width, height) searched, in pixels of the input frame.
        The small scales cost the most; a face under 60 px is too small for
        an AAM fit anyway.
    max_side : int, optional
        If given, frames whose longer side exceeds it are downscaled to it
        before detection (for speed) and the boxes are mapped back; None
        searches at full resolution.
    equalize : bool
        Histogram-equalise the grey image before detection.

    Raises
    ------
    FileNotFoundError
        If the cascade file cannot be found (OpenCV 5 ships none).
    RuntimeError
        If OpenCV has no ``CascadeClassifier`` or cannot load the file.
    ValueError
        For out-of-range parameters.

    Notes
    -----
    One instance should not be shared between threads calling
    :meth:`detect` at the same time; create one per thread.
    """

    def __init__(
        self,
        cascade: str | Path = DEFAULT_CASCADE,
        scale_factor: float = defaults.DETECTOR["scale_factor"],
        min_neighbors: int = defaults.DETECTOR["min_neighbors"],
        min_size: tuple[int, int] = defaults.DETECTOR["min_size"],
        max_side: int | None = defaults.DETECTOR["max_side"],
        equalize: bool = False,
    ) -> None:
        if not scale_factor > 1.0:
            raise ValueError(f"scale_factor must be > 1, got {scale_factor}")
        if min_neighbors < 0:
            raise ValueError(f"min_neighbors must be >= 0, got {min_neighbors}")
        if len(min_size) != 2 or min(min_size) < 1:
            raise ValueError(f"min_size must be two positive ints, got {min_size}")
        if max_side is not None and max_side < 32:
            raise ValueError(f"max_side must be None or >= 32, got {max_side}")
        if not hasattr(cv2, "CascadeClassifier"):
            raise RuntimeError(
                f"this OpenCV ({cv2.__version__}) has no CascadeClassifier. " + _INSTALL_HINT
            )
        self.cascade_file = cascade_path(cascade)
        try:
            self._classifier = cv2.CascadeClassifier(str(self.cascade_file))
            loaded = not self._classifier.empty()
        except (cv2.error, SystemError) as exc:
            raise RuntimeError(
                f"{self.cascade_file}: OpenCV could not load it as a cascade"
            ) from exc
        if not loaded:
            raise RuntimeError(f"{self.cascade_file}: OpenCV could not load it as a cascade")
        self.scale_factor = float(scale_factor)
        self.min_neighbors = int(min_neighbors)
        self.min_size = (int(min_size[0]), int(min_size[1]))
        self.max_side = max_side
        self.equalize = equalize

    def settings(self) -> dict[str, Any]:
        """The search settings, as :meth:`from_settings` takes them (the cascade aside)."""
        return {"scale_factor": self.scale_factor, "min_neighbors": self.min_neighbors,
                "min_size": list(self.min_size), "max_side": self.max_side,
                "equalize": bool(self.equalize)}

    @classmethod
    def from_settings(cls, settings: Mapping[str, Any]) -> HaarFaceDetector:
        """A detector with the default cascade and :meth:`settings` ``settings``.

        Raises
        ------
        ValueError
            For a missing, extra or out-of-range setting.
        """
        names = {"scale_factor", "min_neighbors", "min_size", "max_side", "equalize"}
        if not isinstance(settings, Mapping) or set(settings) != names:
            raise ValueError(f"Haar settings must name exactly {sorted(names)}")
        try:
            size = settings["min_size"]
            max_side = settings["max_side"]
            scale_factor = float(settings["scale_factor"])
            if not np.isfinite(scale_factor):
                raise ValueError(f"scale_factor must be finite, got {scale_factor}")
            return cls(scale_factor=scale_factor,
                       min_neighbors=int(settings["min_neighbors"]),
                       min_size=(int(size[0]), int(size[1])) if len(size) == 2 else (),
                       max_side=None if max_side is None else int(max_side),
                       equalize=bool(settings["equalize"]))
        except (TypeError, IndexError, OverflowError) as exc:
            raise ValueError(f"Haar settings of the wrong type: {exc}") from None

    def __repr__(self) -> str:
        return (
            f"HaarFaceDetector(cascade={self.cascade_file.name!r}, "
            f"scale_factor={self.scale_factor}, min_neighbors={self.min_neighbors}, "
            f"min_size={self.min_size}, max_side={self.max_side}, equalize={self.equalize})"
        )

    def detect(self, image: np.ndarray) -> np.ndarray:
        """Find faces in a frame.

        Parameters
        ----------
        image : (H, W), (H, W, 3) BGR or (H, W, 4) BGRA array
            uint8, uint16 or float (see :func:`to_grey_uint8`).

        Returns
        -------
        (K, 4) float64 array
            Boxes ``x, y, w, h`` in pixels of ``image``, largest area first;
            ``K`` is 0 when no face is found.

        Raises
        ------
        ValueError
            For an empty, None, wrongly shaped or non-finite image.
        """
        grey = to_grey_uint8(image)
        factor = 1.0
        if self.max_side is not None and max(grey.shape) > self.max_side:
            factor = self.max_side / max(grey.shape)
            size = (max(1, round(grey.shape[1] * factor)), max(1, round(grey.shape[0] * factor)))
            grey = cv2.resize(grey, size, interpolation=cv2.INTER_AREA)
        if self.equalize:
            grey = cv2.equalizeHist(grey)
        min_size = (
            max(1, round(self.min_size[0] * factor)),
            max(1, round(self.min_size[1] * factor)),
        )
        found = self._classifier.detectMultiScale(
            grey, scaleFactor=self.scale_factor, minNeighbors=self.min_neighbors, minSize=min_size
        )
        boxes = np.asarray(found, dtype=np.float64).reshape(-1, 4) / factor
        order = np.argsort(-(boxes[:, 2] * boxes[:, 3]), kind="stable")
        return boxes[order]

    def detect_largest(self, image: np.ndarray) -> np.ndarray | None:
        """Return the largest face box ``(4,)`` as ``x, y, w, h``, or None if none is found."""
        boxes = self.detect(image)
        return boxes[0] if len(boxes) else None
