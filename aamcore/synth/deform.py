"""Faces that change shape: expression targets for an annotated photo, and the warp that
makes the photo take them.

:func:`expression_shapes` gives, per frame, the photo's iBUG-68 landmarks moved by an
expression that changes over time (the mouth opening and closing with the jaw, a smile,
the brows raised, the eyes closing), blended toward other faces' shapes aligned to it by a
similarity (their own, real, differences of shape). :func:`reshape` warps a frame
piecewise-affinely, triangle by triangle, so that the face whose landmarks are at
``source`` takes ``target``; a ring of fixed points around the face carries the
surrounding image along and leaves the rest of the frame as it was.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from aamcore.model.similarity import Similarity
from aamcore.warp.piecewise_affine import sample_points
from aamcore.warp.reference_frame import barycentric, delaunay_triangles, rasterise_triangles

RING = 16
"""Fixed points on the circle around the face that bounds the warp."""
RING_RADIUS = 1.1
"""The circle's radius, in the largest extent of the face's landmark box: wide enough to
hold the jaw at its lowest."""
MOUTH_COLOUR = (40, 30, 55)
"""BGR of the inside of an opened mouth."""


def smooth_noise(rng: np.random.Generator, n: int, cycles: float) -> np.ndarray:
    """A smooth random curve (n,) in [-1, 1] with about ``cycles`` oscillations."""
    t = np.linspace(0.0, 1.0, n)
    curve = np.zeros(n)
    for k in range(1, 4):
        curve += rng.normal() / k * np.sin(2 * np.pi * (cycles * k * t + rng.uniform()))
    peak = np.abs(curve).max()
    return curve / peak if peak > 0 else curve


@dataclass(frozen=True)
class ExpressionSpec:
    """How far each expression goes, at its peak.

    Attributes
    ----------
    mouth : float
        Lower lip and chin drop, in outer-eye-corner distances.
    smile : float
        Mouth corners out and up.
    brows : float
        Brows raised.
    blinks : int
        Eye closings over the sequence (each a few frames, the lids 90 % shut).
    blend : float
        Largest weight of another face's aligned shape.
    cycles : float
        How fast the expressions change (oscillations over the sequence).
    seed : int
    """

    mouth: float = 0.35
    smile: float = 0.12
    brows: float = 0.15
    blinks: int = 3
    blend: float = 0.6
    cycles: float = 1.5
    seed: int = 0


# Per point: (right, down) displacement at full expression, in outer-eye-corner distances.
_JAW_DROP = {3: 0.03, 4: 0.09, 5: 0.17, 6: 0.26, 7: 0.32, 8: 0.34, 9: 0.32, 10: 0.26,
             11: 0.17, 12: 0.09, 13: 0.03}
_MOUTH_OPEN = {
    **{k: (0.0, v) for k, v in _JAW_DROP.items()},
    55: (0.0, 0.6), 56: (0.0, 0.9), 57: (0.0, 1.0), 58: (0.0, 0.9), 59: (0.0, 0.6),
    65: (0.0, 0.75), 66: (0.0, 0.9), 67: (0.0, 0.75),
    48: (0.08, 0.35), 54: (-0.08, 0.35), 60: (0.08, 0.35), 64: (-0.08, 0.35),
    50: (0.0, -0.1), 51: (0.0, -0.1), 52: (0.0, -0.1), 61: (0.0, -0.1), 62: (0.0, -0.1),
    63: (0.0, -0.1),
}
_SMILE = {48: (-1.0, -0.6), 54: (1.0, -0.6), 60: (-0.9, -0.5), 64: (0.9, -0.5),
          49: (-0.5, -0.3), 53: (0.5, -0.3), 59: (-0.5, -0.3), 55: (0.5, -0.3),
          61: (-0.3, -0.1), 63: (0.3, -0.1), 67: (-0.3, -0.1), 65: (0.3, -0.1)}
_BROWS = {k: (0.0, -1.0) for k in range(17, 27)} | {19: (0.0, -1.2), 24: (0.0, -1.2)}
_LIDS = ((37, 41), (38, 40), (43, 47), (44, 46))
"""(upper, lower) lid points: a closing eye moves each upper one toward its lower one."""


def _field(points: np.ndarray, table: dict[int, tuple[float, float]]) -> np.ndarray:
    """The displacements (N, 2) of a table in the face's own axes (right, down), pixels."""
    right = points[45] - points[36]
    d = float(np.linalg.norm(right))
    right = right / d
    down = np.array([-right[1], right[0]])
    out = np.zeros_like(points)
    for k, (r, w) in table.items():
        out[k] = d * (r * right + w * down)
    return out


def _curve(rng: np.random.Generator, n: int, cycles: float, rest: float) -> np.ndarray:
    """A smooth curve (n,) in [0, 1] that stays at 0 about ``rest`` of the time."""
    raw = smooth_noise(rng, n, cycles)
    return np.clip((raw - (2 * rest - 1)) / (2 - 2 * rest), 0.0, 1.0)


def _blinks(rng: np.random.Generator, n: int, count: int) -> np.ndarray:
    """Eye closure (n,) in [0, 1]: ``count`` closings of about 5 frames each."""
    t = np.arange(n)
    out = np.zeros(n)
    for centre in rng.uniform(0.05, 0.95, count) * n:
        out = np.maximum(out, np.exp(-0.5 * ((t - centre) / 1.5) ** 2))
    return out


def expression_shapes(points: np.ndarray, others: list[np.ndarray], frames: int,
                      spec: ExpressionSpec = ExpressionSpec()) -> np.ndarray:
    """Per-frame landmarks (F, 68, 2) of ``points`` (68, 2) changing expression over time.

    Parameters
    ----------
    points : (68, 2) array
        The photo's iBUG-68 landmarks.
    others : list of (68, 2) arrays
        Other faces' landmarks; each is aligned onto ``points`` by a least-squares
        similarity and blended in, one after the other, by a smooth weight up to
        ``spec.blend``.
    frames : int
    spec : ExpressionSpec
    """
    rng = np.random.default_rng(spec.seed)
    mouth = spec.mouth * _curve(rng, frames, spec.cycles, 0.35)
    smile = spec.smile * _curve(rng, frames, spec.cycles, 0.5)
    brows = spec.brows * _curve(rng, frames, spec.cycles, 0.5)
    closed = 0.9 * _blinks(rng, frames, spec.blinks)
    fields = [_field(points, t) for t in (_MOUTH_OPEN, _SMILE, _BROWS)]
    out = np.repeat(points[None].astype(np.float64), frames, axis=0)
    out += (mouth[:, None, None] * fields[0] + smile[:, None, None] * fields[1]
            + brows[:, None, None] * fields[2])
    if others:
        # One face after another: each weight rises and falls in its share of the sequence.
        t = np.linspace(0.0, len(others), frames, endpoint=False)
        for k, other in enumerate(others):
            aligned = Similarity.from_estimate(other, points).apply(other)
            weight = spec.blend * np.clip(np.sin(np.pi * (t - k)), 0.0, None) * (t // 1 == k)
            out += weight[:, None, None] * (aligned - points)[None]
    for upper, lower in _LIDS:
        out[:, upper] += closed[:, None] * (out[:, lower] - out[:, upper])
    return out


def _polygon_area(points: np.ndarray) -> float:
    x, y = points[:, 0], points[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, 1)) - np.dot(y, np.roll(x, 1))))


def reshape(frame: np.ndarray, photo: np.ndarray, to_frame: Similarity, source: np.ndarray,
            target: np.ndarray) -> np.ndarray:
    """``frame`` with the face at ``source`` warped, from ``photo``, so that it is at ``target``.

    Each pixel inside the ring of fixed points around the face (Delaunay triangles of
    ``target`` and the ring) is sampled, bilinearly, from where its triangle's affine map
    takes it in the face at ``source``, and from there in ``photo`` (one resampling of the
    photo, not two); pixels outside the ring, or taken from beyond the photo's edge, are
    left as they are. Where the inner lips
    open wider than in the photo, the opening is painted dark.

    Parameters
    ----------
    frame : (H, W, 3) uint8 array
        The photo already placed by ``to_frame``; changed in place and returned.
    photo : (h, w, 3) uint8 array
    to_frame : Similarity
        Photo to frame coordinates.
    source, target : (68, 2) arrays
        The face's landmarks in the frame, and where they are to be.
    """
    height, width = frame.shape[:2]
    centre = source.mean(axis=0)
    radius = RING_RADIUS * float(np.ptp(source, axis=0).max())
    angles = np.linspace(0.0, 2 * np.pi, RING, endpoint=False)
    ring = centre + radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    src, dst = np.vstack([source, ring]), np.vstack([target, ring])
    x0, y0 = np.maximum(np.floor(ring.min(axis=0)).astype(int), 0)
    x1, y1 = np.minimum(np.ceil(ring.max(axis=0)).astype(int), [width - 1, height - 1])
    if x1 < x0 or y1 < y0:
        return frame
    triangles = delaunay_triangles(dst)
    with np.errstate(divide="ignore", invalid="ignore"):
        index = rasterise_triangles(dst - [x0, y0], triangles, (y1 - y0 + 1, x1 - x0 + 1))
    ys, xs = np.nonzero(index >= 0)
    which = index[ys, xs]
    pixels = np.stack([xs + x0, ys + y0], axis=1).astype(np.float64)
    bary = barycentric(pixels, dst, triangles, which)
    corners = triangles[which]
    at = sum(bary[:, [k]] * src[corners[:, k]] for k in range(3))
    in_photo = to_frame.inverse().apply(at)
    # Beyond the photo's edge the frame keeps its background, as the rigid placement does.
    inside = np.all((in_photo >= 0) & (in_photo <= np.array(photo.shape[1::-1]) - 1), axis=1)
    values = sample_points(photo, in_photo[inside])
    frame[ys[inside] + y0, xs[inside] + x0] = np.clip(values, 0, 255).astype(np.uint8)
    inner_t, inner_s = target[60:68], source[60:68]
    area = _polygon_area(inner_t)
    if area > 1.0:
        opened = float(np.clip(1.0 - _polygon_area(inner_s) / area, 0.0, 1.0))
        if opened > 0.05:
            mask = np.zeros((height, width), np.uint8)
            cv2.fillPoly(mask, [np.round(inner_t).astype(np.int32)], 255, cv2.LINE_AA)
            alpha = (0.85 * opened * mask.astype(np.float32) / 255)[..., None]
            frame[:] = (frame * (1 - alpha) + np.array(MOUTH_COLOUR) * alpha).astype(np.uint8)
    return frame
