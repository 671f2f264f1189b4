"""Pictures of a model: mode variations (figures 3.4, 4.8, 5.3) and reconstructions."""

from __future__ import annotations

import cv2
import numpy as np

from aamcore.io.landmarks import LandmarkScheme
from aamcore.model.aam import AAM
from aamcore.model.texture import normalise_texture
from aamcore.warp.piecewise_affine import render_texture

SIGMAS = (-3.0, 0.0, 3.0)
_TEXT = {"fontFace": cv2.FONT_HERSHEY_SIMPLEX, "fontScale": 0.35, "thickness": 1}


def draw_shape(
    canvas: np.ndarray,
    points: np.ndarray,
    scheme: LandmarkScheme,
    colour: tuple[int, int, int] = (0, 255, 0),
    triangles: np.ndarray | None = None,
) -> np.ndarray:
    """Draw landmarks (N, 2), their connectivity and optionally a mesh on ``canvas``."""
    pts = np.round(points).astype(np.int32)
    if triangles is not None:
        for tri in triangles:
            cv2.polylines(canvas, [pts[tri]], True, (160, 160, 160), 1, cv2.LINE_AA)
    for a, b in scheme.edges:
        cv2.line(canvas, tuple(pts[a]), tuple(pts[b]), colour, 1, cv2.LINE_AA)
    for p in pts:
        cv2.circle(canvas, tuple(p), 2, colour, -1, cv2.LINE_AA)
    return canvas


def _display_texture(aam: AAM, g: np.ndarray) -> np.ndarray:
    """Map a normalised texture (M C,) to 0-255 (M, C) for display."""
    return np.clip(g * 50.0 + 128.0, 0, 255).reshape(aam.frame.n_pixels, -1)


def _blank(aam: AAM) -> np.ndarray:
    h, w = aam.frame.size
    return np.full((h, w, 3), 255, dtype=np.uint8)


def _to_bgr(texture: np.ndarray) -> np.ndarray:
    return np.repeat(texture, 3, axis=1) if texture.shape[1] == 1 else texture


def shape_mode_image(aam: AAM, mode: int, sigma: float) -> np.ndarray:
    """The mean shape moved ``sigma`` standard deviations along shape ``mode``."""
    b = np.zeros(aam.shape.n_modes)
    b[mode] = sigma * np.sqrt(aam.shape.pca.variances[mode])
    points = aam.shape.instance(b) + aam.frame.offset
    return draw_shape(_blank(aam), points, aam.scheme, (200, 0, 0), aam.frame.triangles)


def texture_mode_image(aam: AAM, mode: int, sigma: float) -> np.ndarray:
    """The mean texture moved ``sigma`` standard deviations along texture ``mode``."""
    b = np.zeros(aam.texture.n_modes)
    b[mode] = sigma * np.sqrt(aam.texture.pca.variances[mode])
    g, _, _ = normalise_texture(aam.texture.instance(b))
    texture = _to_bgr(_display_texture(aam, g)).astype(np.uint8)
    image = _blank(aam)
    image[aam.frame.mask] = texture
    return image


def combined_mode_image(aam: AAM, mode: int, sigma: float) -> np.ndarray:
    """The model instance moved ``sigma`` standard deviations along appearance ``mode``."""
    c = np.zeros(aam.n_appearance)
    c[mode] = sigma * np.sqrt(aam.combined.pca.variances[mode])
    g, _, _ = normalise_texture(aam.texture_instance(c))
    texture = _to_bgr(_display_texture(aam, g)).astype(np.uint8)
    points = aam.model_shape(c) + aam.frame.offset
    return render_texture(aam.frame, texture, points, _blank(aam))


def modes_figure(aam: AAM, n_modes: int = 3) -> np.ndarray:
    """Grid of the first modes of the shape, texture and combined models at -3, 0, +3 sigma.

    Returns a BGR image with one row per (model, mode) and one column per sigma.
    """
    rows = []
    for name, count, draw in (
        ("shape", aam.shape.n_modes, shape_mode_image),
        ("texture", aam.texture.n_modes, texture_mode_image),
        ("combined", aam.n_appearance, combined_mode_image),
    ):
        for mode in range(min(n_modes, count)):
            tiles = [draw(aam, mode, s) for s in SIGMAS]
            row = np.hstack(
                [
                    cv2.copyMakeBorder(t, 18, 2, 2, 2, cv2.BORDER_CONSTANT, value=(255, 255, 255))
                    for t in tiles
                ]
            )
            for k, s in enumerate(SIGMAS):
                label = f"{name} {mode + 1} {s:+.0f}sd"
                x = k * (tiles[0].shape[1] + 4) + 4
                cv2.putText(row, label, (x, 13), color=(0, 0, 0), **_TEXT)
            rows.append(row)
    return np.vstack(rows)


def reconstruction_figure(aam: AAM, image: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The image beside its model reconstruction (figure 5.2), both with the landmarks.

    The reconstruction paints the model instance of the image's appearance
    parameters over a copy of the image, matching its brightness.
    """
    original = aam.prepare_image(image, points)
    c, t = aam.parameters_of(image, points)
    raw = aam.warp.warp(original, points).ravel()
    _, alpha, beta = normalise_texture(raw)
    canvas = original.copy() if original.ndim == 3 else cv2.cvtColor(original, cv2.COLOR_GRAY2BGR)
    left = canvas.copy()
    right = aam.render(c, t, canvas, alpha, beta)
    draw_shape(left, points, aam.scheme)
    draw_shape(right, aam.shape_instance(c, t), aam.scheme, (0, 0, 255))
    return np.hstack([left, right])
