"""Camera intrinsics: the matrix ``K``, lens distortion and image size.

Read from an OpenCV calibration file (YAML or XML written by
``cv2.FileStorage`` with ``camera_matrix``, ``distortion_coefficients``,
``image_width`` and ``image_height``, as OpenCV's calibration sample writes
them), from a JSON file with the same keys, or assumed from a horizontal field
of view when no calibration exists.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from aamcore.pose.errors import IntrinsicsError

DISTORTION_LENGTHS = (0, 4, 5, 8, 12, 14)
_UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 20, 1e-10)


@dataclass(frozen=True, eq=False)
class CameraIntrinsics:
    """A pinhole camera with optional OpenCV lens distortion.

    Parameters
    ----------
    K : (3, 3) float64 array
        Camera matrix ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]`` in pixels.
    dist : (k,) float64 array
        OpenCV distortion coefficients, k in {0, 4, 5, 8, 12, 14}; empty for none.
    width, height : int
        Image size in pixels the calibration belongs to; 0 and 0 when unknown
        (a bare ``K``).
    source : str
        Where the values come from: a file path, or the assumption made.
    """

    K: np.ndarray
    dist: np.ndarray = field(default_factory=lambda: np.zeros(0))
    width: int = 0
    height: int = 0
    source: str = "given"

    def __post_init__(self) -> None:
        K = np.array(self.K, dtype=np.float64)
        dist = np.array(self.dist if self.dist is not None else [], dtype=np.float64).ravel()
        problem = _problem_with(K, dist, self.width, self.height)
        if problem:
            raise IntrinsicsError(f"camera intrinsics from {self.source}: {problem}")
        K.setflags(write=False)
        dist.setflags(write=False)
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "dist", dist)
        object.__setattr__(self, "width", int(self.width))
        object.__setattr__(self, "height", int(self.height))
        object.__setattr__(self, "_K_inv", np.linalg.inv(K))
        object.__setattr__(self, "_distorted", bool(np.any(dist != 0.0)))

    @property
    def has_distortion(self) -> bool:
        """True if any distortion coefficient is non-zero."""
        return self._distorted  # type: ignore[attr-defined]

    @property
    def focal(self) -> tuple[float, float]:
        """``(fx, fy)`` in pixels."""
        return float(self.K[0, 0]), float(self.K[1, 1])

    @property
    def horizontal_fov_deg(self) -> float:
        """Horizontal field of view in degrees (ignoring distortion)."""
        return float(np.degrees(2.0 * np.arctan(self.width / (2.0 * self.K[0, 0]))))

    @classmethod
    def from_fov(
        cls, width: int, height: int, hfov_deg: float = 60.0
    ) -> CameraIntrinsics:
        """Assume a camera from its horizontal field of view.

        Square pixels, no skew, the principal point at the image centre
        ``((width - 1) / 2, (height - 1) / 2)`` (pixel centres at integers) and
        no distortion; ``source`` states this.
        """
        if not 1.0 <= hfov_deg < 179.0:
            raise IntrinsicsError(f"horizontal field of view {hfov_deg} deg is not in [1, 179)")
        if width <= 0 or height <= 0:
            raise IntrinsicsError(f"image size {width}x{height} is not positive")
        f = (width / 2.0) / np.tan(np.radians(hfov_deg) / 2.0)
        K = np.array([[f, 0.0, (width - 1) / 2.0], [0.0, f, (height - 1) / 2.0], [0, 0, 1.0]])
        source = (
            f"assumed: horizontal FOV {hfov_deg:g} deg, square pixels, principal point at the "
            "image centre, no distortion"
        )
        return cls(K, np.zeros(0), width, height, source)

    @classmethod
    def from_file(
        cls, path: str | Path, width: int | None = None, height: int | None = None
    ) -> CameraIntrinsics:
        """Read a calibration file: ``.yaml``/``.yml``/``.xml`` (OpenCV) or ``.json``.

        Parameters
        ----------
        path : path
            The file. It must hold ``camera_matrix`` and may hold
            ``distortion_coefficients``, ``image_width`` and ``image_height``.
        width, height : int, optional
            Image size, if the file does not give it.

        Raises
        ------
        IntrinsicsError
            Naming the file, if it is missing, does not parse, lacks a key or
            holds implausible values.
        """
        path = Path(path)
        if not path.is_file():
            raise IntrinsicsError(f"{path}: calibration file not found")
        suffix = path.suffix.lower()
        if suffix == ".json":
            values = _read_json(path)
        elif suffix in (".yaml", ".yml", ".xml"):
            values = _read_opencv(path)
        else:
            raise IntrinsicsError(f"{path}: unknown calibration format {suffix!r} "
                                  "(expected .yaml, .yml, .xml or .json)")
        K, dist, file_w, file_h = values
        w = width if width is not None else file_w
        h = height if height is not None else file_h
        if w is None or h is None:
            raise IntrinsicsError(f"{path}: no image_width/image_height in the file; pass them")
        return cls(K, dist, int(w), int(h), str(path))

    def scaled_to(self, width: int, height: int) -> CameraIntrinsics:
        """The same camera at another resolution of the same field of view."""
        sx, sy = width / self.width, height / self.height
        K = self.K.copy()
        K[0] *= sx
        K[1] *= sy
        # Pixel centres sit at integers: the image spans [-0.5, size - 0.5].
        K[0, 2] = (self.K[0, 2] + 0.5) * sx - 0.5
        K[1, 2] = (self.K[1, 2] + 0.5) * sy - 0.5
        return CameraIntrinsics(K, self.dist, width, height, f"{self.source}, scaled to "
                                f"{width}x{height}")

    def normalize(self, points: np.ndarray) -> np.ndarray:
        """Undistorted normalised image coordinates ``K^-1 [u, v, 1]`` of pixels.

        Parameters
        ----------
        points : (N, 2) array
            Pixel coordinates.

        Returns
        -------
        (N, 2) float64 array
        """
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        if self.has_distortion:
            out = cv2.undistortPointsIter(
                pts.reshape(-1, 1, 2), self.K, self.dist, None, None, _UNDISTORT_CRITERIA
            )
            return out.reshape(-1, 2)
        Ki = self._K_inv  # type: ignore[attr-defined]
        return pts @ Ki[:2, :2].T + Ki[:2, 2]

    def project(self, points: np.ndarray, R: np.ndarray, T: np.ndarray) -> np.ndarray:
        """Pixel positions of 3D points seen under pose ``(R, T)``, distortion included.

        Parameters
        ----------
        points : (N, 3) array
            Points in the model frame.
        R : (3, 3) array
            Model-to-camera rotation.
        T : (3,) array
            Model origin in camera coordinates, same units as ``points``.

        Returns
        -------
        (N, 2) float64 array
        """
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        if not self.has_distortion:
            cam = pts @ np.asarray(R).T + np.asarray(T).reshape(1, 3)
            uv1 = cam @ self.K.T
            return uv1[:, :2] / uv1[:, 2:3]
        rvec, _ = cv2.Rodrigues(np.asarray(R, dtype=np.float64))
        out, _ = cv2.projectPoints(pts, rvec, np.asarray(T, np.float64), self.K, self.dist)
        return out.reshape(-1, 2)

    def to_json(self) -> dict[str, Any]:
        """A JSON-serialisable dict that :meth:`from_file` reads back from a ``.json`` file."""
        return {
            "camera_matrix": self.K.tolist(),
            "distortion_coefficients": self.dist.tolist(),
            "image_width": self.width,
            "image_height": self.height,
            "source": self.source,
        }

    def save(self, path: str | Path) -> None:
        """Write a ``.json``, ``.yaml``/``.yml`` or ``.xml`` calibration file."""
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix == ".json":
            path.write_text(json.dumps(self.to_json(), indent=2))
            return
        if suffix not in (".yaml", ".yml", ".xml"):
            raise IntrinsicsError(f"{path}: unknown calibration format {suffix!r}")
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
        try:
            fs.write("image_width", self.width)
            fs.write("image_height", self.height)
            fs.write("camera_matrix", self.K)
            fs.write("distortion_coefficients", self.dist.reshape(-1, 1))
        finally:
            fs.release()


FOCAL_RANGE = (0.005, 100.0)
"""Focal lengths a camera can have, in multiples of the image side: 0.005 for a field of
view of 179 degrees, 100 for 0.6 degrees. Beyond them the pose solvers' numbers overflow (a
calibration with fx = fy = 1e300 made OpenCV's solver raise)."""
MAX_DISTORTION = 1e4
"""Largest distortion coefficient accepted (real lenses stay far below)."""


def _problem_with(K: np.ndarray, dist: np.ndarray, width: int, height: int) -> str:
    """Describe what is wrong with the values, or return an empty string."""
    if K.shape != (3, 3):
        return f"camera_matrix has shape {K.shape}, expected (3, 3)"
    if not np.all(np.isfinite(K)):
        return "camera_matrix has non-finite values"
    if K[0, 0] <= 0 or K[1, 1] <= 0:
        return f"focal lengths fx={K[0, 0]}, fy={K[1, 1]} must be positive"
    if not np.allclose(K[2], [0.0, 0.0, 1.0]) or K[1, 0] != 0.0:
        return f"camera_matrix {K.tolist()} is not of the form [[fx,s,cx],[0,fy,cy],[0,0,1]]"
    if dist.size not in DISTORTION_LENGTHS:
        return f"{dist.size} distortion coefficients; OpenCV uses {DISTORTION_LENGTHS}"
    if not np.all(np.isfinite(dist)):
        return "distortion_coefficients has non-finite values"
    if width == 0 and height == 0:
        return ""  # size unknown: a bare K
    if width <= 0 or height <= 0:
        return f"image size {width}x{height} is not positive"
    if not (0.0 <= K[0, 2] <= width and 0.0 <= K[1, 2] <= height):
        return (
            f"principal point ({K[0, 2]:g}, {K[1, 2]:g}) lies outside the {width}x{height} "
            "image (calibration made at another resolution?)"
        )
    lo, hi = FOCAL_RANGE
    for name, f, side in (("fx", K[0, 0], width), ("fy", K[1, 1], height)):
        if not lo * side <= f <= hi * side:
            return (f"focal length {name}={f:g} px is not {lo:g} to {hi:g} times the image's "
                    f"{side} px (a field of view of 0.6 to 179 degrees)")
    if dist.size and np.max(np.abs(dist)) > MAX_DISTORTION:
        return f"a distortion coefficient of {np.max(np.abs(dist)):g} (at most {MAX_DISTORTION:g})"
    return ""


def _read_opencv(path: Path) -> tuple[np.ndarray, np.ndarray, int | None, int | None]:
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError) as exc:
        # The wrapper raises SystemError with the cv2.error as its cause.
        inner = exc.__cause__ if isinstance(exc.__cause__, cv2.error) else exc
        detail = str(inner).strip().splitlines()[-1].split("error: ")[-1]
        raise IntrinsicsError(f"{path}: does not parse as an OpenCV YAML/XML file "
                              f"({detail})") from exc
    try:
        if not fs.isOpened():
            raise IntrinsicsError(f"{path}: cannot be opened as an OpenCV YAML/XML file")
        node = fs.getNode("camera_matrix")
        K = None if node.empty() else node.mat()
        if K is None:
            raise IntrinsicsError(f"{path}: no camera_matrix matrix in the file")
        node = fs.getNode("distortion_coefficients")
        dist = np.zeros(0) if node.empty() else node.mat()
        if dist is None:
            raise IntrinsicsError(f"{path}: distortion_coefficients is not a matrix")
        sizes = []
        for key in ("image_width", "image_height"):
            node = fs.getNode(key)
            if not node.empty() and not (node.isInt() or node.isReal()):
                raise IntrinsicsError(f"{path}: {key} is not a number")
            sizes.append(None if node.empty() else _size(node.real(), path, key))
    finally:
        fs.release()
    return np.asarray(K, np.float64), np.asarray(dist, np.float64).ravel(), sizes[0], sizes[1]


def _size(value: float, path: Path, key: str) -> int:
    """An image size in pixels read from a calibration file: a positive whole number."""
    if not math.isfinite(value) or value < 1 or value > 1e6 or value != int(value):
        raise IntrinsicsError(f"{path}: {key} is {value!r}, not a positive whole number of pixels")
    return int(value)


def _json_matrix(value: Any, path: Path, key: str) -> np.ndarray:
    # OpenCV's own JSON writer stores {"rows", "cols", "dt", "data"}.
    if isinstance(value, dict):
        value = value.get("data")
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise IntrinsicsError(f"{path}: {key} is not a numeric array") from exc
    return arr


def _read_json(path: Path) -> tuple[np.ndarray, np.ndarray, int | None, int | None]:
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise IntrinsicsError(f"{path}: does not parse as JSON ({exc})") from exc
    if not isinstance(data, dict) or "camera_matrix" not in data:
        raise IntrinsicsError(f"{path}: no camera_matrix key in the JSON object")
    K = _json_matrix(data["camera_matrix"], path, "camera_matrix")
    if K.size == 9:
        K = K.reshape(3, 3)
    dist = _json_matrix(data.get("distortion_coefficients", []), path, "distortion_coefficients")
    sizes = []
    for key in ("image_width", "image_height"):
        value = data.get(key)
        if value is not None and not isinstance(value, int | float):
            raise IntrinsicsError(f"{path}: {key} is not a number")
        sizes.append(None if value is None else _size(value, path, key))
    return K, dist.ravel(), sizes[0], sizes[1]
