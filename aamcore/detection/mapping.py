"""Start shapes for an AAM search from a face box (thesis section 7.2).

An AAM search starts from the mean shape placed on the face. This module
learns where to place it: for every training image the Haar detection is
matched to the ground truth, the similarity transform that puts the reference
shape (the model's mean shape, centred at the origin) on the ground-truth
landmarks is found by Procrustes, and its parameters are regressed on the box,
box-relative:

    scale = a * w,   tx = cx + b * w,   ty = cy + c * w,   rotation = d

with ``(cx, cy)`` the box centre and ``w`` its width. ``d`` is zero unless
rotation is fitted. The same is learned from the landmark box (the tight box
of the ground-truth points), the fallback when the detector finds nothing, or
to re-start from a previous frame's fitted shape.

"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from aamcore.detection.boxes import as_box, landmark_box, match_detection
from aamcore.io.landmarks import as_points
from aamcore.model.similarity import Similarity

BoxSource = Literal["detector", "landmarks"]


def _check_reference(reference: np.ndarray) -> np.ndarray:
    ref = as_points(reference, "reference shape")
    size = float(np.sqrt(np.mean(np.sum(ref**2, axis=1))))
    if size == 0.0:
        raise ValueError("reference shape has all points at one place")
    if np.linalg.norm(ref.mean(axis=0)) > 1e-6 * size:
        raise ValueError(
            f"reference shape must be centred at the origin, its centroid is {ref.mean(axis=0)}"
        )
    return ref


def similarity_onto(
    reference: np.ndarray, points: np.ndarray, with_rotation: bool = False
) -> Similarity:
    """Least-squares similarity putting a centred reference shape on ``points``.

    Minimises ``sum_j |s R(theta) ref_j + t - points_j|^2``; without rotation,
    ``theta`` is held at zero.

    Parameters
    ----------
    reference : (N, 2) array, centred at the origin
    points : (N, 2) array
    with_rotation : bool

    Returns
    -------
    Similarity
    """
    ref = _check_reference(reference)
    pts = as_points(points)
    if pts.shape != ref.shape:
        raise ValueError(f"points shape {pts.shape} differs from reference {ref.shape}")
    if with_rotation:
        return Similarity.from_estimate(ref, pts)
    # With the reference centred, t is the centroid and s the projection of points on ref.
    t = pts.mean(axis=0)
    return Similarity(float(np.sum(ref * (pts - t)) / np.sum(ref**2)), 0.0, float(t[0]),
                      float(t[1]))


@dataclass(frozen=True)
class BoxMapping:
    """Box-relative similarity: ``scale = a w``, ``t = centre + (b, c) w``, ``rotation``.

    Attributes
    ----------
    a, b, c : float
        Fitted coefficients (see the module docstring).
    rotation : float
        Constant rotation in radians (zero unless fitted).
    with_rotation : bool
        Whether the rotation was fitted (the Procrustes fits then include it).
    """

    a: float
    b: float
    c: float
    rotation: float = 0.0
    with_rotation: bool = False

    def transform(self, box: np.ndarray) -> Similarity:
        """The similarity placing the reference shape on a box ``x, y, w, h``."""
        x, y, w, h = as_box(box)
        cx, cy = x + w / 2, y + h / 2
        return Similarity.from_scale_angle(self.a * w, self.rotation,
                                           (cx + self.b * w, cy + self.c * w))

    def place(self, reference: np.ndarray, box: np.ndarray) -> np.ndarray:
        """Put the (N, 2) reference shape on ``box``; returns (N, 2) points."""
        return self.transform(box).apply(reference)

    @classmethod
    def naive(cls, reference: np.ndarray) -> BoxMapping:
        """Reference scaled to the box width and centred on the box (not learned)."""
        ref = _check_reference(reference)
        width = float(np.ptp(ref[:, 0]))
        return cls(a=1.0 / width, b=0.0, c=0.0)

    @classmethod
    def fit(
        cls,
        reference: np.ndarray,
        boxes: np.ndarray,
        shapes: np.ndarray,
        fit_rotation: bool = False,
    ) -> BoxMapping:
        """Fit ``a, b, c`` (and the rotation) by least squares.

        The residuals are taken box-relative (divided by ``w``), so that every
        face counts the same whatever its size; the least-squares solution is
        then the mean of each box-relative Procrustes parameter.

        Parameters
        ----------
        reference : (N, 2) array, centred at the origin
        boxes : (M, 4) array
            One box ``x, y, w, h`` per training shape.
        shapes : (M, N, 2) array
            Ground-truth landmarks.
        fit_rotation : bool
            Also fit a constant rotation (mean Procrustes angle).

        Raises
        ------
        ValueError
            If there are no samples or the shapes disagree.
        """
        rel = _relative_params(reference, boxes, shapes, fit_rotation)
        scale, tx, ty = rel[:, :3].mean(axis=0)
        rotation = math.atan2(np.mean(np.sin(rel[:, 3])), np.mean(np.cos(rel[:, 3])))
        return cls(float(scale), float(tx), float(ty), float(rotation), fit_rotation)

    def residuals(
        self, reference: np.ndarray, boxes: np.ndarray, shapes: np.ndarray
    ) -> dict[str, float]:
        """How well the mapping fits ``M`` samples.

        Returns
        -------
        dict
            ``rms_scale``: RMS relative scale error; ``rms_tx``, ``rms_ty``:
            RMS translation residuals over box width; ``mean_point_error``: mean point-to-point
            distance of the placed shapes to the ground truth over box width.
        """
        rel = _relative_params(reference, boxes, shapes, self.with_rotation)
        res = rel[:, :3] - np.array([self.a, self.b, self.c])
        res[:, 0] /= self.a  # relative scale error, free of the reference's size
        widths = np.asarray(boxes, dtype=np.float64)[:, 2]
        errors = [
            np.mean(np.linalg.norm(self.place(reference, box) - shape, axis=1)) / w
            for box, shape, w in zip(boxes, shapes, widths, strict=True)
        ]
        rms = np.sqrt(np.mean(res**2, axis=0))
        return {
            "rms_scale": float(rms[0]),
            "rms_tx": float(rms[1]),
            "rms_ty": float(rms[2]),
            "mean_point_error": float(np.mean(errors)),
        }

    def to_json(self) -> dict[str, float | bool]:
        """Plain-float description."""
        return {
            "a": self.a,
            "b": self.b,
            "c": self.c,
            "rotation": self.rotation,
            "with_rotation": self.with_rotation,
        }

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> BoxMapping:
        """Rebuild a mapping written by :meth:`to_json`."""
        return cls(
            float(data["a"]),
            float(data["b"]),
            float(data["c"]),
            float(data.get("rotation", 0.0)),
            bool(data.get("with_rotation", False)),
        )


def _relative_params(
    reference: np.ndarray, boxes: np.ndarray, shapes: np.ndarray, with_rotation: bool
) -> np.ndarray:
    """Box-relative Procrustes parameters, (M, 4): ``s/w, (tx-cx)/w, (ty-cy)/w, theta``."""
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    shapes = np.asarray(shapes, dtype=np.float64)
    if len(boxes) == 0:
        raise ValueError("no training samples to fit a box mapping")
    if shapes.ndim != 3 or len(shapes) != len(boxes):
        raise ValueError(
            f"need one (N, 2) shape per box: {len(boxes)} boxes, shapes {shapes.shape}"
        )
    rows = []
    for box, shape in zip(boxes, shapes, strict=True):
        x, y, w, h = as_box(box)
        sim = similarity_onto(reference, shape, with_rotation)
        rows.append([sim.scale / w, (sim.tx - x - w / 2) / w, (sim.ty - y - h / 2) / w,
                     sim.angle if with_rotation else 0.0])
    return np.array(rows)


@dataclass(frozen=True)
class BoxToShapeMapping:
    """Learned placement of the reference shape on detector or landmark boxes.

    Attributes
    ----------
    reference : (N, 2) float64 array
        The reference shape (the model's mean shape), centred at the origin.
    detector : BoxMapping
        Mapping from a Haar detection box.
    landmarks : BoxMapping
        Mapping from a landmark box (the fallback).
    detection_rate : float
        Fraction of training images with a detection matched to the face.
    n_train : int
        Number of training images.
    residual : dict
        ``{"detector": {...}, "landmarks": {...}}`` from :meth:`BoxMapping.residuals`.
    """

    reference: np.ndarray
    detector: BoxMapping
    landmarks: BoxMapping
    detection_rate: float = float("nan")
    n_train: int = 0
    residual: dict[str, dict[str, float]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "reference", _check_reference(self.reference))

    def place(self, box: np.ndarray, source: BoxSource = "detector") -> np.ndarray:
        """Start shape (N, 2) for a box ``x, y, w, h``.

        Parameters
        ----------
        box : (4,) array
        source : ``"detector"`` or ``"landmarks"``
            What the box is: a Haar detection, or the tight box of landmarks
            (ground truth, or a previous frame's fitted shape).
        """
        return self.mapping(source).place(self.reference, box)

    def transform(self, box: np.ndarray, source: BoxSource = "detector") -> Similarity:
        """The similarity that :meth:`place` applies."""
        return self.mapping(source).transform(box)

    def mapping(self, source: BoxSource) -> BoxMapping:
        """The :class:`BoxMapping` for ``source``."""
        if source == "detector":
            return self.detector
        if source == "landmarks":
            return self.landmarks
        raise ValueError(f"box source must be 'detector' or 'landmarks', got {source!r}")

    def to_json(self, include_reference: bool = True) -> dict[str, Any]:
        """Plain-float description for a model file's JSON header.

        Leave out the reference (``include_reference=False``) when the file
        stores the mean shape anyway; pass it back to :meth:`from_json`.
        """
        data: dict[str, Any] = {
            "detector": self.detector.to_json(),
            "landmarks": self.landmarks.to_json(),
            "detection_rate": float(self.detection_rate),
            "n_train": int(self.n_train),
            "residual": {k: {m: float(v) for m, v in d.items()} for k, d in self.residual.items()},
        }
        if include_reference:
            data["reference"] = self.reference.tolist()
        return data

    @classmethod
    def from_json(
        cls, data: dict[str, Any], reference: np.ndarray | None = None
    ) -> BoxToShapeMapping:
        """Rebuild a mapping written by :meth:`to_json`.

        Raises
        ------
        ValueError
            If ``data`` holds no reference shape and none is given, or a key
            is missing.
        """
        if reference is None:
            if "reference" not in data:
                raise ValueError("box-to-shape JSON holds no reference shape: pass reference=")
            reference = np.asarray(data["reference"], dtype=np.float64)
        try:
            return cls(
                reference=np.asarray(reference, dtype=np.float64),
                detector=BoxMapping.from_json(data["detector"]),
                landmarks=BoxMapping.from_json(data["landmarks"]),
                detection_rate=float(data.get("detection_rate", float("nan"))),
                n_train=int(data.get("n_train", 0)),
                residual={k: dict(v) for k, v in data.get("residual", {}).items()},
            )
        except KeyError as exc:
            raise ValueError(f"box-to-shape JSON lacks the key {exc}") from exc


def fit_box_to_shape(
    reference: np.ndarray,
    shapes: Sequence[np.ndarray],
    detections: Sequence[np.ndarray],
    fit_rotation: bool = False,
) -> BoxToShapeMapping:
    """Learn a :class:`BoxToShapeMapping` from shapes and their detections.

    Parameters
    ----------
    reference : (N, 2) array, centred at the origin
    shapes : sequence of M (N, 2) arrays
        Ground-truth landmarks.
    detections : sequence of M (K, 4) arrays
        All detector boxes of each image (K may be 0).
    fit_rotation : bool
        Also fit a constant rotation.

    Raises
    ------
    ValueError
        If the lengths differ, there is no shape, or no detection matches.
    """
    if len(shapes) != len(detections):
        raise ValueError(f"{len(shapes)} shapes but {len(detections)} detection lists")
    if len(shapes) == 0:
        raise ValueError("no training shapes")
    stack = np.stack([as_points(s) for s in shapes])
    matched = [match_detection(d, s) for d, s in zip(detections, stack, strict=True)]
    hit = [k for k, m in enumerate(matched) if m is not None]
    if not hit:
        raise ValueError(f"no detection matched any of the {len(shapes)} training faces")
    det_boxes = np.array([np.asarray(detections[k]).reshape(-1, 4)[matched[k]] for k in hit])
    lm_boxes = np.array([landmark_box(s) for s in stack])
    detector = BoxMapping.fit(reference, det_boxes, stack[hit], fit_rotation)
    landmarks = BoxMapping.fit(reference, lm_boxes, stack, fit_rotation)
    return BoxToShapeMapping(
        reference=np.asarray(reference, dtype=np.float64),
        detector=detector,
        landmarks=landmarks,
        detection_rate=len(hit) / len(shapes),
        n_train=len(shapes),
        residual={
            "detector": detector.residuals(reference, det_boxes, stack[hit]),
            "landmarks": landmarks.residuals(reference, lm_boxes, stack),
        },
    )
