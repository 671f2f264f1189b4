"""Face boxes ``(x, y, w, h)``: from landmarks, their overlap, and which detection is whose."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from aamcore.detection.haar import HaarFaceDetector
from aamcore.io import FaceSample
from aamcore.io.landmarks import as_points


def as_box(box: np.ndarray) -> np.ndarray:
    """``box`` as 4 finite float64 numbers ``x, y, w, h`` with ``w, h > 0``.

    Raises
    ------
    ValueError
    """
    arr = np.asarray(box, dtype=np.float64).reshape(-1)
    if arr.shape != (4,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"box must be 4 finite numbers x, y, w, h, got {box!r}")
    if arr[2] <= 0 or arr[3] <= 0:
        raise ValueError(f"box width and height must be positive, got {arr.tolist()}")
    return arr


def landmark_box(points: np.ndarray) -> np.ndarray:
    """Tight bounding box ``(4,)`` ``x, y, w, h`` of ``points`` of shape (N, 2)."""
    pts = as_points(points)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    return np.array([lo[0], lo[1], hi[0] - lo[0], hi[1] - lo[1]])


def box_iou(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two boxes ``x, y, w, h``."""
    ix = max(0.0, min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0]))
    iy = max(0.0, min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1]))
    inter = ix * iy
    union = a[2] * a[3] + b[2] * b[3] - inter
    return float(inter / union) if union > 0 else 0.0


def match_detection(boxes: np.ndarray, points: np.ndarray) -> int | None:
    """Pick the detection that belongs to a ground-truth face.

    Parameters
    ----------
    boxes : (K, 4) array
        Detections ``x, y, w, h``.
    points : (N, 2) array
        Ground-truth landmarks.

    Returns
    -------
    int or None
        Index of the detection whose centre lies inside the landmark box,
        with the largest IoU with it if several do; None if none does.
    """
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    gt = landmark_box(points)
    best, best_iou = None, -1.0
    for k, box in enumerate(boxes):
        cx, cy = box[0] + box[2] / 2, box[1] + box[3] / 2
        inside = gt[0] <= cx <= gt[0] + gt[2] and gt[1] <= cy <= gt[1] + gt[3]
        iou = box_iou(box, gt)
        if inside and iou > best_iou:
            best, best_iou = k, iou
    return best


def detect_all(samples: Sequence[FaceSample], detector: HaarFaceDetector) -> list[np.ndarray]:
    """Run the detector on every sample's image; one (K, 4) array per sample."""
    return [detector.detect(sample.load_image()) for sample in samples]
