"""Training faces of the local-binary cascade: grey, shrunk, mirrored, packed for sampling."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from aamcore.io.landmarks import mirror_points


@dataclass(frozen=True)
class TrainingFace:
    """A grey training image with its landmarks and its start shape.

    Attributes
    ----------
    grey : (H, W) uint8 array
    points : (N, 2) float64 array
        The true landmarks.
    start : (N, 2) float64 array
        The start shape a fit of this face begins from (a Haar box through the
        box-to-shape mapping, or the landmark box where Haar missed).
    detected : bool
        Whether ``start`` comes from a detection.
    photo : int
        The photo the face comes from (a mirror image shares it): cross-fitting
        folds never split a photo.
    """

    grey: np.ndarray
    points: np.ndarray
    start: np.ndarray
    detected: bool
    photo: int = 0


def shrink_face(image: np.ndarray, points: np.ndarray, max_width: float = 200.0
                ) -> tuple[np.ndarray, float]:
    """``image`` as a grey (H, W) uint8 image shrunk so that the landmarks ``points`` (N, 2)
    span at most ``max_width`` px (for memory: faces of 640x360 frames are smaller), and
    the factor it was shrunk by (1 where it was small enough)."""
    grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image
    width = float(np.ptp(np.asarray(points)[:, 0]))
    if width <= max_width:
        return grey, 1.0
    f = max_width / width
    size = (max(1, round(grey.shape[1] * f)), max(1, round(grey.shape[0] * f)))
    return cv2.resize(grey, size, interpolation=cv2.INTER_AREA), size[0] / grey.shape[1]


def scaled(points: np.ndarray, f: float) -> np.ndarray:
    """Points (N, 2) in an image scaled by ``f`` (pixel centres: ``x' + 0.5 = (x + 0.5) f``)."""
    return (np.asarray(points, np.float64) + 0.5) * f - 0.5


def prepare_faces(
    greys: Sequence[np.ndarray],
    factors: Sequence[float],
    points: Sequence[np.ndarray],
    starts: Sequence[np.ndarray],
    detected: Sequence[bool],
    mirror: np.ndarray | None,
) -> list[TrainingFace]:
    """Training faces, and (with a ``mirror`` permutation) their mirror images.

    Parameters
    ----------
    greys : sequence of (H, W) uint8 arrays
        The images as :func:`shrink_face` made them.
    factors : sequence of float
        The factor each was shrunk by.
    points, starts : sequences of (N, 2) arrays
        True landmarks and start shapes in the original images' pixels.
    detected : sequence of bool
    mirror : (N,) int array, optional
        Also add each face flipped left-right, its points renumbered by it
        (:data:`aamcore.io.landmarks.IBUG68_MIRROR`).
    """
    faces = []
    for photo, (grey, f, pts, start, hit) in enumerate(
            zip(greys, factors, points, starts, detected, strict=True)):
        pts_small, start_small = scaled(pts, f), scaled(start, f)
        faces.append(TrainingFace(grey, pts_small, start_small, bool(hit), photo))
        if mirror is not None:
            w = grey.shape[1]
            faces.append(TrainingFace(cv2.flip(grey, 1), mirror_points(pts_small, w, mirror),
                                      mirror_points(start_small, w, mirror), bool(hit), photo))
    return faces


@dataclass
class PackedImages:
    """Grey training images in one flat array, for vectorised pixel sampling.

    Attributes
    ----------
    pixels : (P,) uint8 array
    base : (I,) int64 array
        Offset of each image's first pixel.
    width, height : (I,) int64 arrays
    """

    pixels: np.ndarray
    base: np.ndarray
    width: np.ndarray
    height: np.ndarray

    @classmethod
    def pack(cls, images: Sequence[np.ndarray]) -> PackedImages:
        """Pack (H, W) uint8 grey images."""
        sizes = np.array([im.size for im in images], dtype=np.int64)
        base = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
        return cls(np.concatenate([im.ravel() for im in images]), base,
                   np.array([im.shape[1] for im in images], dtype=np.int64),
                   np.array([im.shape[0] for im in images], dtype=np.int64))

    def differences(self, owners: np.ndarray, anchors: np.ndarray, ab: np.ndarray,
                    offsets: np.ndarray) -> np.ndarray:
        """Pixel differences ``I(p1) - I(p2)`` (S, P) float32, as the fitter samples them.

        Parameters
        ----------
        owners : (S,) int array
            Image of each sample.
        anchors : (S, 2) array
            Landmark position of each sample (image pixels).
        ab : (S, 2) array
            Similarity ``(a, b)`` of each sample's current shape.
        offsets : (P, 4) array
            Pixel pairs ``(x1, y1, x2, y2)`` in model-frame units.
        """
        out = np.empty((len(owners), len(offsets)), dtype=np.float32)
        chunk = max(1, 2_000_000 // max(len(offsets), 1))
        for lo in range(0, len(owners), chunk):
            sl = slice(lo, lo + chunk)
            own = owners[sl]
            a, b = ab[sl, 0:1], ab[sl, 1:2]
            ax, ay = anchors[sl, 0:1] + 0.5, anchors[sl, 1:2] + 0.5
            w, h, base = self.width[own, None], self.height[own, None], self.base[own, None]
            values = []
            for k in (0, 2):
                ox, oy = offsets[None, :, k], offsets[None, :, k + 1]
                x = np.maximum(a * ox - b * oy + ax, 0.0).astype(np.int64)
                y = np.maximum(b * ox + a * oy + ay, 0.0).astype(np.int64)
                np.minimum(x, w - 1, out=x)
                np.minimum(y, h - 1, out=y)
                values.append(self.pixels.take(base + y * w + x).astype(np.int16))
            out[sl] = values[0] - values[1]
        return out
