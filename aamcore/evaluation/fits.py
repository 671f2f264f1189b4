"""Measuring fits as thesis section 7.3 does, and as the field does today.

- :func:`monte_carlo`: fits from starts displaced along x or y from the
  centre-of-gravity start and from the Haar start (tables 7.1, 7.2,
  figures 7.7, 7.8).
- :func:`landmark_errors`: fits every image from its Haar box (the landmark
  box when Haar finds nothing, counted), for NME statistics.
- :func:`held_out`: the samples a model was not trained on.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field

import numpy as np

from aamcore import defaults
from aamcore.detection.boxes import landmark_box, match_detection
from aamcore.detection.haar import HaarFaceDetector
from aamcore.detection.mapping import BoxToShapeMapping
from aamcore.evaluation.metrics import (
    nme,
    part_nmes,
    point_to_border,
    point_to_point,
    procrustes_distance,
    summarise,
)
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.result import AAMFit
from aamcore.io import FaceSample
from aamcore.io.landmarks import as_points
from aamcore.model.aam import AAM
from aamcore.model.similarity import Similarity

STARTS = defaults.FIT_STARTS
THESIS_OFFSETS = defaults.THESIS_OFFSETS


def cog_start(
    mapping: BoxToShapeMapping, points: np.ndarray, box: np.ndarray | None = None
) -> np.ndarray:
    """The thesis's centre-of-gravity start (section 7.3).

    The reference shape scaled (and rotated) as the mapping says and centred
    on the centroid of the ground-truth ``points``.

    Parameters
    ----------
    mapping : BoxToShapeMapping
    points : (N, 2) array
        Ground-truth landmarks.
    box : (4,) array, optional
        A detector box giving the scale; by default the scale comes from the
        landmark box of ``points`` through the fallback mapping.

    Returns
    -------
    (N, 2) array
    """
    pts = as_points(points)
    if box is None:
        sim = mapping.transform(landmark_box(pts), "landmarks")
    else:
        sim = mapping.transform(box, "detector")
    centre = pts.mean(axis=0)
    return Similarity(sim.a, sim.b, float(centre[0]), float(centre[1])).apply(mapping.reference)



@dataclass(frozen=True)
class FitRecord:
    """One fit and its errors.

    Attributes
    ----------
    image : str
        Image file name.
    start : str
        ``cog``, ``haar`` or ``landmarks`` (the Haar fallback).
    axis : str
        ``x`` or ``y`` for a displaced start, ``""`` otherwise.
    offset : float
        Start displacement in pixels.
    nme, pt_pt, pt_border, procrustes, texture : float
        Errors (eqs. 7.4-7.7 and the inter-ocular NME).
    failed : bool
        The fitter's own failure test (eq. 7.2).
    iterations : int
    seconds : float
    parts : dict of str to float
        NME of each named group of the scheme's points (``jaw``, ``mouth``, ...).
    """

    image: str
    start: str
    axis: str
    offset: float
    nme: float
    pt_pt: float
    pt_border: float
    procrustes: float
    texture: float
    failed: bool
    iterations: int
    seconds: float
    parts: dict[str, float] = field(default_factory=dict)


def held_out(aam: AAM, samples: Sequence[FaceSample]) -> list[FaceSample]:
    """The ``samples`` whose image (by content, :meth:`FaceSample.image_id`) and subject the
    model was not trained on (neither the AAM nor its fitting parts: ``fit_images``)."""
    trained = set(aam.summary.get("train_images", [])) | set(aam.summary.get("fit_images", []))
    subjects = set(aam.summary.get("train_subjects", []))
    return [
        s
        for s in samples
        if s.image_id() not in trained and (s.subject is None or s.subject not in subjects)
    ]


def _record(
    fitter: Fitter,
    image: np.ndarray,
    sample: FaceSample,
    start: np.ndarray,
    kind: str,
    axis: str = "",
    offset: float = 0.0,
) -> FitRecord:
    scheme = fitter.aam.scheme
    t0 = time.perf_counter()
    result = fitter.fit_shape(image, start)
    seconds = time.perf_counter() - t0
    gt = sample.points
    return FitRecord(
        sample.image_path.name,
        kind,
        axis,
        float(offset),
        nme(result.points, gt, scheme),
        point_to_point(result.points, gt),
        point_to_border(result.points, gt, scheme),
        procrustes_distance(result.points, gt),
        float(result.error) if isinstance(result, AAMFit) else math.nan,
        bool(result.failed),
        int(result.iterations) if isinstance(result, AAMFit) else len(result.seconds),
        seconds,
        part_nmes(result.points, gt, scheme),
    )


def haar_box(
    detector: HaarFaceDetector, image: np.ndarray, points: np.ndarray
) -> np.ndarray | None:
    """The detection that matches the annotated face, or None."""
    boxes = detector.detect(image)
    k = match_detection(boxes, points)
    return None if k is None else boxes[k]


def monte_carlo(
    fitter: Fitter,
    samples: Iterable[FaceSample],
    offsets: Sequence[float],
    starts: Sequence[str] = STARTS,
    axes: Sequence[str] = ("x", "y"),
    detector: HaarFaceDetector | None = None,
) -> list[FitRecord]:
    """Fit every sample from every displaced start (thesis section 7.3).

    Each fit starts from the mean face (``c = 0``). The CoG start centres the
    mean shape on the annotation's centre of gravity at the scale the
    box mapping gives; the Haar start places it by the detection (images
    where Haar misses the face are left out of the Haar runs).
    """
    detector = detector or HaarFaceDetector()
    records = []
    for sample in samples:
        image = sample.load_image()
        bases = {}
        if "cog" in starts:
            bases["cog"] = cog_start(fitter.mapping, sample.points)
        if "haar" in starts:
            box = haar_box(detector, image, sample.points)
            if box is not None:
                bases["haar"] = fitter.mapping.place(box, "detector")
        for kind, base in bases.items():
            for axis in axes:
                shift = np.array([1.0, 0.0]) if axis == "x" else np.array([0.0, 1.0])
                for offset in offsets:
                    records.append(
                        _record(fitter, image, sample, base + offset * shift, kind, axis, offset)
                    )
    return records


def landmark_errors(
    fitter: Fitter, samples: Iterable[FaceSample], detector: HaarFaceDetector | None = None
) -> list[FitRecord]:
    """Fit each sample from its Haar box, or from its landmark box when Haar misses."""
    detector = detector or HaarFaceDetector()
    records = []
    for sample in samples:
        image = sample.load_image()
        box = haar_box(detector, image, sample.points)
        if box is not None:
            start, kind = fitter.mapping.place(box, "detector"), "haar"
        else:
            start, kind = (
                fitter.mapping.place(landmark_box(sample.points), "landmarks"),
                "landmarks",
            )
        records.append(_record(fitter, image, sample, start, kind))
    return records


def failure_rates(records: Sequence[FitRecord], threshold: float = 0.10) -> dict:
    """Failure percentages by start, axis and offset.

    Returns ``{start: {axis: {offset: {"eq72": %, "nme": %, "n": count}}}}``
    where ``eq72`` is the thesis's test and ``nme`` counts fits over
    ``threshold``.
    """
    table: dict = {}
    for r in records:
        cell = (
            table.setdefault(r.start, {})
            .setdefault(r.axis, {})
            .setdefault(r.offset, {"eq72": 0.0, "nme": 0.0, "n": 0})
        )
        cell["n"] += 1
        cell["eq72"] += r.failed
        cell["nme"] += r.nme > threshold
    for axes in table.values():
        for offsets in axes.values():
            for cell in offsets.values():
                cell["eq72"] = 100.0 * cell["eq72"] / cell["n"]
                cell["nme"] = 100.0 * cell["nme"] / cell["n"]
    return table


def format_failure_table(rates: dict, key: str = "eq72") -> str:
    """Failure rates in the layout of thesis table 7.1 (Tx, -Tx, Ty, -Ty columns)."""
    x, y = rates.get("x", {}), rates.get("y", {})
    positive = sorted(o for o in set(x) | set(y) if o > 0)
    lines = [
        f"{'Tx':>5} {'Fail%':>6} {'Tx':>5} {'Fail%':>6} {'Ty':>5} {'Fail%':>6} {'Ty':>5} "
        f"{'Fail%':>6}"
    ]

    def cell(axis: dict, offset: float) -> str:
        return (
            f"{offset:>5g} {axis[offset][key]:>6.2f}"
            if offset in axis
            else f"{offset:>5g} {'-':>6}"
        )

    for o in positive:
        lines.append(" ".join([cell(x, o), cell(x, -o), cell(y, o), cell(y, -o)]))
    if 0 in x or 0 in y:
        zero = x.get(0) or y.get(0)
        lines.append(f"(Tx=0, Ty=0) -> failure {zero[key]:.2f}%")
    return "\n".join(lines)


def summary(records: Sequence[FitRecord]) -> dict:
    """NME statistics, mean metrics and time per fit of ``records``."""
    if not records:
        raise ValueError("no fits to summarise")
    stats = asdict(summarise([r.nme for r in records]))
    for name in ("pt_pt", "pt_border", "procrustes", "texture", "iterations", "seconds"):
        stats[f"mean_{name}"] = float(np.mean([getattr(r, name) for r in records]))
    stats["eq72_failure"] = float(np.mean([r.failed for r in records]))
    stats["landmark_box_starts"] = sum(r.start == "landmarks" for r in records)
    return stats
