"""Video with exact landmarks on every frame, made from one annotated photograph.

The photo is moved over a 640 x 360 canvas by a smooth random similarity
(translation, in-plane rotation up to +-30 deg, scale 0.7 to 1.4 of its
starting size), with brightness changes, motion blur while it moves fast, and
optionally an occluder for a stretch of frames: by default a skin-coloured,
hand-sized shape that crosses the face (``crossing``); or one of the kinds of
:mod:`aamcore.fitting.occluders` (a hand, an object, hair,
sunglasses) resting on the face and moving with it; or the frame's edge
(``edge``: the face slides partly out of the frame). Landmarks follow by the
same transform, so every frame has its ground truth; frames covered by the
occluder are flagged, and per landmark the share of its part of the face the
occluder covers (a disc of :data:`PART_RADIUS` of the face's width around it;
for the kinds other than ``crossing`` the part outside the frame counts as
hidden).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from aamcore.fitting.occluders import DRAWN, draw_occluder
from aamcore.fitting.occluders import covered_shares as hidden_shares
from aamcore.model.similarity import Similarity
from aamcore.synth.deform import reshape, smooth_noise

SIZE = (640, 360)
"""Canvas width and height."""
FACE_WIDTH = 150.0
"""Width in pixels of the face's landmark box at scale 1."""
PART_RADIUS = 0.08
"""Radius of a landmark's part of the face, in face widths (landmark-box widths): about the
eye's half width on a frontal face."""


@dataclass(frozen=True)
class MotionSpec:
    """How a sequence moves.

    Attributes
    ----------
    frames : int
    max_angle_deg : float
        Largest in-plane rotation.
    scales : (float, float)
        Smallest and largest scale, relative to the start.
    speed : float
        How fast the random motion changes (cycles over the sequence).
    brightness : float
        Amplitude of the brightness changes, grey levels.
    blur : bool
        Motion blur along the motion, as long as the frame's displacement.
    occluder : (int, int) or None
        First and last frame (inclusive) of the occluder's crossing.
    occluder_kind : str
        ``crossing`` (the hand crossing the face), one of
        :data:`aamcore.fitting.occluders.DRAWN` or ``edge``.
    noise : float
        Standard deviation of per-frame sensor noise, grey levels.
    seed : int
    """

    frames: int = 150
    max_angle_deg: float = 30.0
    scales: tuple[float, float] = (0.7, 1.4)
    speed: float = 2.0
    brightness: float = 30.0
    blur: bool = True
    occluder: tuple[int, int] | None = None
    noise: float = 0.0
    seed: int = 0
    occluder_kind: str = "crossing"


@dataclass(frozen=True)
class Sequence:
    """A generated sequence.

    Attributes
    ----------
    frames : list of (360, 640, 3) uint8 arrays
    landmarks : (F, N, 2) float64 array
        The exact landmarks of every frame.
    occluded : (F,) bool array
        Frames where the occluder covers part of the face.
    covered : (F, N) float array
        Per frame and landmark, the share of the landmark's part of the face (a disc of
        :data:`PART_RADIUS` face widths) the occluder covers, 0 to 1.
    """

    frames: list[np.ndarray]
    landmarks: np.ndarray
    occluded: np.ndarray
    covered: np.ndarray



def trajectory(spec: MotionSpec, points: np.ndarray) -> list[Similarity]:
    """Per-frame similarities taking the photo's landmarks ``points`` (N, 2) onto the canvas."""
    rng = np.random.default_rng(spec.seed)
    n = spec.frames
    lo, hi = points.min(axis=0), points.max(axis=0)
    base = FACE_WIDTH / float(hi[0] - lo[0])
    centre = (lo + hi) / 2
    log_lo, log_hi = np.log(spec.scales[0]), np.log(spec.scales[1])
    scale = np.exp((log_lo + log_hi) / 2 + (log_hi - log_lo) / 2 * smooth_noise(rng, n, 1.0))
    angle = np.radians(spec.max_angle_deg) * smooth_noise(rng, n, spec.speed)
    margin = np.array([SIZE[0], SIZE[1]]) / 2 - FACE_WIDTH * 0.8
    shift = np.stack([margin[0] * smooth_noise(rng, n, spec.speed),
                      margin[1] * smooth_noise(rng, n, spec.speed)], axis=1)
    if spec.occluder is not None and spec.occluder_kind == "edge":
        shift = _to_the_edge(spec, shift, FACE_WIDTH * scale, rng)
    out = []
    for k in range(n):
        s = Similarity.from_scale_angle(base * scale[k], angle[k])
        target = np.array(SIZE) / 2 + shift[k]
        moved = s.apply(centre[None])[0]
        out.append(Similarity(s.a, s.b, target[0] - moved[0], target[1] - moved[1]))
    return out


def _to_the_edge(spec: MotionSpec, shift: np.ndarray, widths: np.ndarray,
                 rng: np.random.Generator) -> np.ndarray:
    """``shift`` (F, 2) taking the face, over the occluder's span, toward an edge of the frame
    until a quarter to a half of its width (``widths`` (F,) pixels) lies beyond it."""
    first, last = spec.occluder  # type: ignore[misc]
    side = int(rng.integers(4))
    axis, sign = side // 2, 1.0 if side % 2 else -1.0
    half = np.array(SIZE, np.float64)[axis] / 2
    beyond = rng.uniform(0.25, 0.5)
    out = shift.copy()
    for k in range(first, last + 1):
        ramp = min((k - first) / 4.0, (last - k) / 4.0, 1.0)
        target = sign * (half + (beyond - 0.5) * widths[k])
        out[k, axis] = shift[k, axis] + ramp * (target - shift[k, axis])
    return out


def _occluder(frame: np.ndarray, k: int, span: tuple[int, int], box: np.ndarray,
              mask: np.ndarray) -> bool:
    """Draw the hand at frame ``k`` of its crossing ``span`` over a face ``box``, and into
    ``mask`` (H, W) uint8 as 255; whether it covers the face."""
    first, last = span
    if not first <= k <= last:
        return False
    x0, y0, x1, y1 = box
    w = x1 - x0
    progress = (k - first) / max(last - first, 1)
    cx = x0 - 0.6 * w + progress * 2.2 * w
    cy = (y0 + y1) / 2 + 0.15 * (y1 - y0)
    axes = (int(0.45 * w), int(0.6 * (y1 - y0)))
    cv2.ellipse(frame, (int(cx), int(cy)), axes, 20, 0, 360, (120, 150, 200), -1)
    cv2.ellipse(mask, (int(cx), int(cy)), axes, 20, 0, 360, 255, -1)
    fingers = [(int(cx + axes[0] * 0.7), int(cy - axes[1] * (0.5 - 0.25 * j))) for j in range(4)]
    for fx, fy in fingers:
        cv2.ellipse(frame, (fx, fy), (int(0.25 * w), int(0.07 * w)), 10, 0, 360,
                    (115, 145, 195), -1)
        cv2.ellipse(mask, (fx, fy), (int(0.25 * w), int(0.07 * w)), 10, 0, 360, 255, -1)
    return cx + axes[0] > x0 and cx - axes[0] < x1


def covered_shares(mask: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Per landmark (N,), the share of its disc of :data:`PART_RADIUS` face widths that
    ``mask`` (H, W) marks (non-zero)."""
    radius = max(PART_RADIUS * float(np.ptp(points[:, 0])), 1.0)
    height, width = mask.shape
    r = int(np.ceil(radius))
    dy, dx = np.mgrid[-r:r + 1, -r:r + 1]
    disc = dx * dx + dy * dy <= radius * radius
    out = np.zeros(len(points))
    for n, (x, y) in enumerate(np.round(points).astype(int)):
        ys, xs = y + dy[disc], x + dx[disc]
        inside = (xs >= 0) & (xs < width) & (ys >= 0) & (ys < height)
        out[n] = float(np.mean(mask[ys[inside], xs[inside]] > 0)) if inside.any() else 0.0
    return out


def _blur(frame: np.ndarray, motion: np.ndarray) -> np.ndarray:
    length = int(round(float(np.linalg.norm(motion))))
    if length < 2:
        return frame
    kernel = np.zeros((length, length), np.float32)
    kernel[length // 2, :] = 1.0 / length
    angle = np.degrees(np.arctan2(motion[1], motion[0]))
    rot = cv2.getRotationMatrix2D((length / 2 - 0.5, length / 2 - 0.5), -angle, 1.0)
    kernel = cv2.warpAffine(kernel, rot, (length, length))
    kernel /= max(float(kernel.sum()), 1e-6)
    return cv2.filter2D(frame, -1, kernel)


def generate(photo: np.ndarray, points: np.ndarray, spec: MotionSpec = MotionSpec(),
             shapes: np.ndarray | None = None) -> Sequence:
    """A sequence of ``photo`` (H, W, 3) with its landmarks ``points`` (N, 2) moving as ``spec``.

    With ``shapes`` (F, N, 2), the face also changes shape: on frame ``k`` the photo is
    warped (:func:`aamcore.synth.deform.reshape`) so that its landmarks, in the photo's
    coordinates, are at ``shapes[k]`` before the motion moves them; they are that frame's
    truth.
    """
    if shapes is not None and shapes.shape != (spec.frames, *points.shape):
        raise ValueError(f"shapes {shapes.shape} for {spec.frames} frames of {points.shape}")
    rng = np.random.default_rng(spec.seed + 1)
    sims = trajectory(spec, points)
    kind = spec.occluder_kind if spec.occluder is not None else "crossing"
    if kind not in ("crossing", "edge", *DRAWN):
        raise ValueError(f"unknown occluder kind {kind!r}")
    covering = None
    if kind in DRAWN:  # drawn on the photo once: it rests on the face and moves with it
        covering = draw_occluder(photo, points, np.random.default_rng(spec.seed + 2), kind,
                                 cv2.flip(photo, -1))
    light = spec.brightness * smooth_noise(rng, spec.frames, 1.5)
    frames, truths, occluded, covered = [], [], [], []
    background = cv2.resize(cv2.GaussianBlur(photo, (0, 0), 25), SIZE)
    for k, sim in enumerate(sims):
        during = spec.occluder is not None and spec.occluder[0] <= k <= spec.occluder[1]
        shown = covering[0] if covering is not None and during else photo
        frame = cv2.warpAffine(shown, sim.matrix, SIZE, dst=background.copy(),
                               borderMode=cv2.BORDER_TRANSPARENT)
        truth = sim.apply(points)
        if shapes is not None:
            target = sim.apply(shapes[k])
            frame = reshape(frame, photo, sim, truth, target)
            truth = target
        if spec.blur and k > 0:
            frame = _blur(frame, truth.mean(axis=0) - truths[-1].mean(axis=0))
        shade = light[k] + (rng.normal(0, spec.noise, frame.shape) if spec.noise else 0)
        frame = np.clip(frame.astype(np.float32) + shade, 0, 255).astype(np.uint8)
        box = np.r_[truth.min(axis=0), truth.max(axis=0)]
        mask = np.zeros(frame.shape[:2], np.uint8)
        if kind == "crossing":
            over = spec.occluder is not None and _occluder(frame, k, spec.occluder, box, mask)
            shares = covered_shares(mask, truth) if over else np.zeros(len(truth))
        else:
            if covering is not None and during:
                mask = cv2.warpAffine(covering[1].astype(np.uint8), sim.matrix, SIZE,
                                      flags=cv2.INTER_NEAREST)
            shares = hidden_shares(mask, truth) if during else np.zeros(len(truth))
            over = bool(shares.max() > 0)
        frames.append(frame)
        truths.append(truth)
        occluded.append(over)
        covered.append(shares)
    return Sequence(frames, np.stack(truths), np.array(occluded), np.stack(covered))
