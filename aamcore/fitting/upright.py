"""Fitting a rolled face in a rotated view of the frame, where it stands upright.

The Haar cascade finds faces rolled by up to about 20 degrees, and a fit from a
detection starts upright; a face rolled further is found and fitted in the
frame turned by its roll (:func:`rotated_view`), and the fit is mapped back
(:func:`mapped`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import cv2
import numpy as np

from aamcore.fitting.result import FitResult
from aamcore.model.similarity import Similarity


def rotated_view(image: np.ndarray, angle: float, about: np.ndarray | None = None
                 ) -> tuple[np.ndarray, Similarity]:
    """``image`` turned by ``-angle`` (radians) about its centre (or ``about``), the same size.

    Parameters
    ----------
    image : (H, W) or (H, W, C) array
    angle : float
        The roll to undo, counter-clockwise in ``(x, y)`` (``Similarity.angle``).
    about : (2,) array, optional
        The point turned about, which stays where it is (the image's centre by default).

    Returns
    -------
    view : array like ``image``
        Corners from outside the frame repeat its edge pixels.
    to_view : Similarity
        Maps points of ``image`` to points of ``view``.
    """
    height, width = image.shape[:2]
    centre = np.array([(width - 1) / 2, (height - 1) / 2]) if about is None else about
    turn = Similarity.from_scale_angle(1.0, -angle)
    tx, ty = centre - turn.apply(centre[None])[0]
    to_view = Similarity(turn.a, turn.b, float(tx), float(ty))
    view = cv2.warpAffine(image, to_view.matrix, (width, height), flags=cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_REPLICATE)
    return view, to_view


def mapped(result: FitResult, transform: Similarity) -> FitResult:
    """``result`` with its landmarks and placement moved by ``transform`` (a copy)."""
    return replace(result, points=transform.apply(result.points),
                   similarity=transform @ result.similarity)


def roll_of(result: FitResult) -> float:
    """The in-plane rotation of a fit, radians (its model frame's angle in the image)."""
    angle = result.similarity.angle
    return angle if math.isfinite(angle) else 0.0
