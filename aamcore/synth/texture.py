"""A face texture in the mesh's UV space, warped from an annotated photograph.

The photo's 68 landmarks and the head's landmark UVs are corresponding
points; a piecewise-affine warp over a Delaunay triangulation of them (plus a
ring of points scaled out from the face, so that forehead and cheeks beyond
the landmarks get the photo's skin too) carries the photo into texture space.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from scipy.spatial import Delaunay

from aamcore.io import load_annotated_folder, read_image
from aamcore.pose.head_model import openface68
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.synth.head import SynthHead

TEXTURE_SIZE = 1024
RING_SCALE = 1.6  # how far the extra ring of points lies from the face centre
_OUTLINE = list(range(0, 17)) + list(range(26, 16, -1))  # jaw then brows, around the face


@dataclass(frozen=True, eq=False)
class FaceTexture:
    """A texture image for the head.

    Attributes
    ----------
    image : (S, S, 3) uint8 array
        BGR; row 0 is the top of the texture (``v = 1`` in OBJ coordinates).
    source : str
        The photo it was made from.
    """

    image: np.ndarray
    source: str


def _ring(points: np.ndarray, scale: float) -> np.ndarray:
    outline = points[_OUTLINE]
    centre = points[27:36].mean(axis=0)  # the nose
    return centre + scale * (outline - centre)


def uv_to_pixels(uv: np.ndarray, size: int) -> np.ndarray:
    """OBJ texture coordinates (v up) to texture pixel coordinates (row 0 on top), (N, 2)."""
    return np.column_stack([uv[:, 0] * size - 0.5, (1.0 - uv[:, 1]) * size - 0.5])


def warp_piecewise_affine(
    image: np.ndarray, src: np.ndarray, dst: np.ndarray, triangles: np.ndarray,
    size: tuple[int, int], fill: np.ndarray,
) -> np.ndarray:
    """Warp ``image`` so that each triangle of ``src`` points lands on that of ``dst``.

    Parameters
    ----------
    image : (H, W, 3) uint8 array
    src, dst : (N, 2) arrays
        Corresponding points in the image and in the output.
    triangles : (T, 3) int array
    size : (width, height)
        Output size.
    fill : (3,) array
        Colour of output pixels no triangle covers.
    """
    out = np.empty((size[1], size[0], 3), np.uint8)
    out[:] = fill.astype(np.uint8)
    for tri in triangles:
        d = dst[tri].astype(np.float32)
        x0, y0 = np.floor(d.min(axis=0)).astype(int)
        x1, y1 = np.ceil(d.max(axis=0)).astype(int) + 1
        x0, y0 = max(x0, 0), max(y0, 0)
        x1, y1 = min(x1, size[0]), min(y1, size[1])
        if x1 <= x0 or y1 <= y0:
            continue
        local = (d - np.array([x0, y0], np.float32)).astype(np.float32)
        A = cv2.getAffineTransform(src[tri].astype(np.float32), local)
        patch = cv2.warpAffine(image, A, (x1 - x0, y1 - y0), flags=cv2.INTER_LINEAR,
                               borderMode=cv2.BORDER_REPLICATE)
        mask = np.zeros((y1 - y0, x1 - x0), np.uint8)
        cv2.fillConvexPoly(mask, np.round(local * 16).astype(np.int32), 1, cv2.LINE_8, 4)
        region = out[y0:y1, x0:x1]
        region[mask > 0] = patch[mask > 0]
    return out


def face_texture(
    head: SynthHead, photo: np.ndarray, landmarks: np.ndarray, source: str = "photo",
    size: int = TEXTURE_SIZE,
) -> FaceTexture:
    """Texture the head from a photo and its 68 iBUG landmarks.

    Parameters
    ----------
    head : SynthHead
    photo : (H, W, 3) uint8 array
        BGR image.
    landmarks : (68, 2) array
        Its landmarks, 0-based pixels.
    source : str
        Name recorded in the result.
    size : int
        Texture side, pixels.

    Raises
    ------
    ValueError
        If the landmarks are not (68, 2) finite values.
    """
    landmarks = np.asarray(landmarks, dtype=np.float64)
    if landmarks.shape != (68, 2) or not np.all(np.isfinite(landmarks)):
        raise ValueError(f"need 68 finite iBUG landmarks, got shape {landmarks.shape}")
    uv_px = uv_to_pixels(head.landmark_uvs, size)
    src = np.vstack([landmarks, _ring(landmarks, RING_SCALE)])
    dst = np.vstack([uv_px, np.clip(_ring(uv_px, RING_SCALE), 0, size - 1)])
    triangles = Delaunay(dst).simplices
    hull = cv2.convexHull(landmarks.astype(np.float32)).astype(np.int32)
    mask = np.zeros(photo.shape[:2], np.uint8)
    cv2.fillConvexPoly(mask, hull, 1)
    fill = np.array(cv2.mean(photo, mask=mask)[:3])
    image = warp_piecewise_affine(photo, src, dst, triangles, (size, size), fill)
    return FaceTexture(image, source)


def frontal_lfpw_photo(folder: Path, limit: int = 150) -> tuple[np.ndarray, np.ndarray, str]:
    """The most frontal, largest face among the first LFPW images: (photo, landmarks, name).

    Frontal by the POSIT pose of its landmarks (smallest largest angle); among
    faces within 8 degrees of that, the one with the widest eye distance.
    """
    samples = load_annotated_folder(folder, limit=limit).samples
    posit = openface68().posit()
    scored = []
    for s in samples:
        size = int(s.points.max() * 1.2)
        est = posit.estimate(s.points, CameraIntrinsics.from_fov(size, size, 50.0))
        if est.reliable:
            eyes = float(np.linalg.norm(s.points[36] - s.points[45]))
            scored.append((float(np.max(np.abs(est.rpy))), -eyes, s))
    if not scored:
        raise ValueError(f"{folder}: no usable annotated face")
    best_angle = min(a for a, _, _ in scored)
    candidates = [(e, str(s.image_path), s) for a, e, s in scored if a <= best_angle + 8.0]
    chosen = min(candidates, key=lambda c: (c[0], c[1]))[2]
    return read_image(chosen.image_path), chosen.points, chosen.image_path.name
