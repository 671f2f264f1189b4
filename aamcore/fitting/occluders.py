"""Occluders drawn over a face: what the occlusion test learns from and is judged on.

Each kind is what covers faces in real footage:

- ``hand``: a palm and fingers, or a fist, in a skin tone (a palette from light
  to dark, or the face's own tone), lit by a gentle ramp;
- ``object``: a cup, a phone, a microphone or a strap: a polygon, a rounded box
  or a bar, flat, shaded, or with the pattern of another photograph;
- ``hair``: a fringe or a lock falling over the brows and eyes, dark to blond
  strands;
- ``glasses``: sunglasses, whose dark lenses hide the eyes (thin frames of
  clear glasses hide little, and their lenses are not counted as covering);
- ``edge``: no drawing; the face cut by the frame's edge (see :func:`edge_crop`).

:func:`draw_occluder` returns the image drawn and the mask of what covers the
face; :func:`covered_shares` turns a mask into per-landmark truth (the share of
each landmark's part of the face that is hidden).
"""

from __future__ import annotations

import cv2
import numpy as np

KINDS = ("hand", "object", "hair", "glasses", "edge")
"""Every kind, in the order the benches cycle through them."""
DRAWN = KINDS[:4]
"""The kinds drawn over the image (``edge`` crops it instead)."""
PART_RADIUS = 0.08
"""Radius of a landmark's part of the face, in face widths (landmark-box widths): about the
eye's half width on a frontal face."""
SKIN = np.array([[189, 209, 241], [160, 190, 226], [120, 150, 200], [96, 128, 180],
                 [70, 100, 150], [50, 72, 110], [34, 50, 80]], np.float64)
"""Skin tones (BGR) from light to dark."""
HAIR = np.array([[20, 20, 25], [30, 45, 70], [45, 75, 120], [90, 140, 190], [60, 60, 70]],
                np.float64)
"""Hair colours (BGR): black, dark brown, brown, blond, grey-brown."""


def covered_shares(mask: np.ndarray, points: np.ndarray, outside_covers: bool = True
                   ) -> np.ndarray:
    """Per landmark (N,), the share of its disc of :data:`PART_RADIUS` face widths that
    ``mask`` (H, W) marks (non-zero); the part of a disc outside the image counts as hidden
    where ``outside_covers``, else it is left out."""
    radius = max(PART_RADIUS * float(np.ptp(points[:, 0])), 1.0)
    height, width = mask.shape
    r = int(np.ceil(radius))
    dy, dx = np.mgrid[-r:r + 1, -r:r + 1]
    disc = dx * dx + dy * dy <= radius * radius
    dx, dy = dx[disc], dy[disc]
    centres = np.round(np.where(np.isfinite(points), points, -1e6)).astype(np.int64)
    xs, ys = centres[:, :1] + dx, centres[:, 1:] + dy  # (N, D): each landmark's disc
    inside = (xs >= 0) & (xs < width) & (ys >= 0) & (ys < height)
    hidden = np.zeros(xs.shape, bool)
    hidden[inside] = mask[ys[inside], xs[inside]] != 0
    hidden_n, inside_n = hidden.sum(axis=1), inside.sum(axis=1)
    if outside_covers:
        return (hidden_n + (len(dx) - inside_n)) / len(dx)
    return np.where(inside_n > 0, hidden_n / np.maximum(inside_n, 1), 0.0)


def face_colour(image: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The mean colour (3,) of the face's landmark box."""
    lo = np.maximum(np.floor(points.min(axis=0)).astype(int), 0)
    hi = np.maximum(np.ceil(points.max(axis=0)).astype(int), lo + 1)
    region = image[lo[1]:hi[1], lo[0]:hi[0]].reshape(-1, image.shape[2] if image.ndim == 3 else 1)
    return region.mean(axis=0) if len(region) else np.full(3, 128.0)


def draw_occluder(image: np.ndarray, points: np.ndarray, rng: np.random.Generator,
                  kind: str | None = None, other: np.ndarray | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """``image`` (H, W, 3) uint8 with an occluder of ``kind`` (one of :data:`DRAWN`; drawn
    at random when None) over part of the face at ``points`` (N, 2), and the mask (H, W)
    bool of what it hides; ``other`` (h, w, 3) lends its pixels to patterned objects."""
    kind = kind or DRAWN[int(rng.integers(len(DRAWN)))]
    if kind not in DRAWN:
        raise ValueError(f"unknown occluder {kind!r}: choose one of {DRAWN}")
    height, width = image.shape[:2]
    alpha = np.zeros((height, width), np.float32)
    layer = np.zeros((height, width, 3), np.float32)
    hidden = _DRAW[kind](alpha, layer, image, points, rng, other)
    soft = rng.uniform(0, 2.0)
    if soft > 0.3 and kind != "glasses":
        alpha = cv2.GaussianBlur(alpha, (0, 0), soft)
    mask = hidden if hidden is not None else alpha > 0.5
    out = image.copy()
    ys, xs = np.nonzero(alpha)
    if len(xs):  # blended where the occluder lies: elsewhere alpha 0 leaves the image as it is
        box = np.s_[ys.min():ys.max() + 1, xs.min():xs.max() + 1]
        a = alpha[box][..., None]
        blended = image[box].astype(np.float32) * (1 - a) + layer[box] * a
        out[box] = np.clip(blended, 0, 255).astype(np.uint8)
    return out, mask


def edge_crop(image: np.ndarray, points: np.ndarray, rng: np.random.Generator,
              share: tuple[float, float] = (0.15, 0.45)) -> tuple[np.ndarray, np.ndarray]:
    """``image`` cut so that a ``share`` of the face's width (or height) lies beyond one of
    its edges, and the shift (2,) taking the original coordinates into the cut image."""
    height, width = image.shape[:2]
    lo, hi = points.min(axis=0), points.max(axis=0)
    side = int(rng.integers(4))
    cut = rng.uniform(*share)
    x0, y0, x1, y1 = 0, 0, width, height
    if side == 0:
        x0 = int(np.clip(lo[0] + cut * (hi[0] - lo[0]), 0, width - 2))
    elif side == 1:
        x1 = int(np.clip(hi[0] - cut * (hi[0] - lo[0]), 2, width))
    elif side == 2:
        y0 = int(np.clip(lo[1] + cut * (hi[1] - lo[1]), 0, height - 2))
    else:
        y1 = int(np.clip(hi[1] - cut * (hi[1] - lo[1]), 2, height))
    return np.ascontiguousarray(image[y0:y1, x0:x1]), np.array([-x0, -y0], np.float64)


def _size(points: np.ndarray) -> float:
    return float(np.ptp(points[:, 0]))


def _pt(p: np.ndarray) -> tuple[int, int]:
    return int(round(float(p[0]))), int(round(float(p[1])))


def _axes(a: float, b: float) -> tuple[int, int]:
    return max(int(a), 1), max(int(b), 1)


def _shade(layer: np.ndarray, alpha: np.ndarray, colour: np.ndarray, rng: np.random.Generator,
           texture: float = 3.0) -> None:
    """Fill the layer under ``alpha`` with ``colour`` lit by a ramp, with a little noise."""
    ys, xs = np.nonzero(alpha)
    if len(xs) == 0:
        return
    x0, x1, y0, y1 = xs.min(), xs.max() + 1, ys.min(), ys.max() + 1
    h, w = y1 - y0, x1 - x0
    angle = rng.uniform(0, 2 * np.pi)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    ramp = (np.cos(angle) * xx / max(w, 1) + np.sin(angle) * yy / max(h, 1)) - 0.5
    light = 1.0 + rng.uniform(0, 0.35) * ramp
    noise = rng.normal(0, texture, (h, w, 1)).astype(np.float32) if texture else 0.0
    layer[y0:y1, x0:x1] = colour[None, None, :] * light[..., None] + noise


def _skin(image: np.ndarray, points: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    if rng.random() < 0.4:
        base = face_colour(image, points) * rng.uniform(0.85, 1.15)
    else:
        base = SKIN[int(rng.integers(len(SKIN)))] * rng.uniform(0.85, 1.15)
    return np.clip(base + rng.normal(0, 6, 3), 0, 255)


def _hand(alpha, layer, image, points, rng, other) -> None:
    face = _size(points)
    centre = points[int(rng.integers(len(points)))] + rng.normal(0, 0.12 * face, 2)
    size = face * rng.uniform(0.2, 0.45)
    angle = rng.uniform(0, 360)
    cv2.ellipse(alpha, _pt(centre), _axes(size, size * rng.uniform(0.6, 1.1)), angle, 0, 360,
                1.0, -1)
    direction = np.array([np.cos(np.radians(angle)), np.sin(np.radians(angle))])
    across = np.array([-direction[1], direction[0]])
    fingers = int(rng.integers(0, 5))
    length = size * rng.uniform(0.5, 1.0)
    for k in range(fingers):
        base = centre + direction * size * 0.8 + across * size * (0.45 - 0.3 * k)
        tip = base + direction * length
        cv2.line(alpha, _pt(base), _pt(tip), 1.0, max(int(size * 0.28), 2), cv2.LINE_AA)
    _shade(layer, alpha, _skin(image, points, rng), rng)


def _object(alpha, layer, image, points, rng, other) -> None:
    face = _size(points)
    centre = points[int(rng.integers(len(points)))] + rng.normal(0, 0.1 * face, 2)
    size = face * rng.uniform(0.2, 0.5)
    shape = int(rng.integers(3))
    if shape == 0:  # a polygon
        n = int(rng.integers(3, 8))
        angles = np.sort(rng.uniform(0, 2 * np.pi, n))
        radii = size * rng.uniform(0.5, 1.0, n)
        corners = centre + np.stack([np.cos(angles), np.sin(angles)], axis=1) * radii[:, None]
        cv2.fillPoly(alpha, [np.round(corners).astype(np.int32)], 1.0)
    elif shape == 1:  # a phone, a cup: a rotated box
        box = ((float(centre[0]), float(centre[1])),
               (float(size * rng.uniform(0.6, 1.4)), float(size * rng.uniform(1.0, 2.0))),
               float(rng.uniform(0, 180)))
        cv2.fillPoly(alpha, [np.round(cv2.boxPoints(box)).astype(np.int32)], 1.0)
    else:  # a microphone, a pen, a strap
        angle = rng.uniform(0, np.pi)
        half = np.array([np.cos(angle), np.sin(angle)]) * face
        cv2.line(alpha, _pt(centre - half), _pt(centre + half), 1.0,
                 max(int(size * rng.uniform(0.2, 0.6)), 2))
    fill = int(rng.integers(3))
    if fill == 2 and other is not None:
        ys, xs = np.nonzero(alpha)
        if len(xs):
            x0, y0, x1, y1 = xs.min(), ys.min(), xs.max() + 1, ys.max() + 1
            oh, ow = other.shape[:2]
            sx = int(rng.integers(0, max(ow - (x1 - x0), 1)))
            sy = int(rng.integers(0, max(oh - (y1 - y0), 1)))
            patch = other[sy:sy + y1 - y0, sx:sx + x1 - x0]
            layer[y0:y1, x0:x1] = cv2.resize(patch, (x1 - x0, y1 - y0)).astype(np.float32)
        return
    _shade(layer, alpha, rng.uniform(0, 255, 3), rng, texture=0.0 if fill == 0 else 8.0)


def _hair(alpha, layer, image, points, rng, other) -> None:
    face = _size(points)
    lo, hi = points.min(axis=0), points.max(axis=0)
    colour = HAIR[int(rng.integers(len(HAIR)))] * rng.uniform(0.8, 1.2)
    side = rng.uniform(-0.5, 0.5)  # where the lock falls across the face
    top = np.array([lo[0] + (0.5 + side) * face, lo[1] - 0.25 * face])
    strands = int(rng.integers(8, 20))
    reach = rng.uniform(0.3, 0.75) * (hi[1] - lo[1])
    width = rng.uniform(0.15, 0.45) * face
    strand = np.zeros_like(alpha)
    for _ in range(strands):
        start = top + np.array([rng.uniform(-width, width), 0])
        bend = rng.normal(0, 0.1 * face)
        curve = np.array([start + np.array([bend * np.sin(t * np.pi / 2), reach * t])
                          for t in np.linspace(0, 1, 8) * rng.uniform(0.7, 1.0)])
        thick = max(int(face * rng.uniform(0.03, 0.08)), 2)
        cv2.polylines(alpha, [np.round(curve).astype(np.int32)], False, 1.0, thick, cv2.LINE_AA)
        cv2.polylines(strand, [np.round(curve).astype(np.int32)], False,
                      float(rng.uniform(0.6, 1.4)), max(thick // 2, 1))
    _shade(layer, alpha, colour, rng, texture=6.0)
    layer *= np.where(strand > 0, strand, 1.0)[..., None]


def _glasses(alpha, layer, image, points, rng, other) -> np.ndarray:
    """Sunglasses: dark lenses (what they hide) in a frame, a bridge and the arms."""
    n = len(points)
    face = _size(points)
    if n == 68:
        eyes = [points[36:42].mean(axis=0), points[42:48].mean(axis=0)]
    else:  # another markup: the upper third of the face, left and right
        lo, hi = points.min(axis=0), points.max(axis=0)
        y = lo[1] + 0.35 * (hi[1] - lo[1])
        eyes = [np.array([lo[0] + 0.3 * face, y]), np.array([lo[0] + 0.7 * face, y])]
    tilt = np.degrees(np.arctan2(eyes[1][1] - eyes[0][1], eyes[1][0] - eyes[0][0]))
    axes = _axes(face * rng.uniform(0.15, 0.2), face * rng.uniform(0.1, 0.15))
    lens = np.zeros_like(alpha)
    for eye in eyes:
        cv2.ellipse(lens, _pt(eye), axes, tilt, 0, 360, 1.0, -1)
    rim = max(int(face * rng.uniform(0.01, 0.03)), 1)
    frame = np.zeros_like(alpha)
    for eye in eyes:
        cv2.ellipse(frame, _pt(eye), axes, tilt, 0, 360, 1.0, rim)
    cv2.line(frame, _pt(eyes[0] + [axes[0] * 0.9, 0]), _pt(eyes[1] - [axes[0] * 0.9, 0]), 1.0,
             rim)
    for eye, sign in zip(eyes, (-1, 1), strict=True):
        cv2.line(frame, _pt(eye + [sign * axes[0], 0]), _pt(eye + [sign * face * 0.55, -2]),
                 1.0, rim)
    tint = rng.uniform(5, 60) * np.array([1.0, rng.uniform(0.9, 1.1), rng.uniform(0.9, 1.1)])
    alpha[:] = np.maximum(lens * rng.uniform(0.85, 1.0), frame)
    layer[:] = np.where(frame[..., None] > 0, rng.uniform(0, 80, 3), tint)
    return lens > 0.5


_DRAW = {"hand": _hand, "object": _object, "hair": _hair, "glasses": _glasses}
