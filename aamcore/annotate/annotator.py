"""The annotator: the glasses by the overlay stage's operator, then the 2D drawing, frame by
frame."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from aamcore.annotate.draw import FaceDrawing
from aamcore.ar.cover import covered_points
from aamcore.face_result import FaceResult
from aamcore.io.landmarks import scheme_for
from aamcore.operators.faces import FacePose
from aamcore.operators.overlay import OverlayOperator


class Annotator:
    """Draws frames' results on them (see :mod:`aamcore.annotate`).

    Parameters
    ----------
    glasses : bool
        Draw the glasses at each reliable pose. They need an OpenGL context (EGL; made in
        the calling thread on the first frame with a pose): where none can be made, the
        rest is drawn and :attr:`glasses_problem` says why the glasses are not.

    All calls must come from one thread (the GL context's).
    """

    def __init__(self, glasses: bool = True) -> None:
        self.glasses = glasses
        self.glasses_problem = ""
        self.overlay = OverlayOperator()
        self._drawings: dict[int, FaceDrawing] = {}
        """By number of landmarks: the colours of each scheme worked out once."""

    def draw(self, frame: np.ndarray, faces: Sequence[FaceResult], K: np.ndarray | None
             ) -> np.ndarray:
        """``frame`` (BGR uint8) with ``faces`` drawn on it, a new image; ``K`` the camera
        matrix of their poses (None: neither axes nor glasses)."""
        image = np.array(frame, dtype=np.uint8, copy=True)
        if image.ndim == 2:
            image = np.repeat(image[:, :, None], 3, axis=2)
        poses = [FacePose(f.face_id, f.rotation, f.translation_mm, K=K, reliable=True,
                          covered=covered_points(f.landmarks, f.occluded))
                 for f in faces if f.pose_reliable and f.rotation is not None]
        if poses and K is not None and self.glasses and self._can_draw(image):
            image = self.overlay(image, poses)
        n = next((len(f.landmarks) for f in faces if len(f.landmarks)), 0)
        if n not in self._drawings:
            self._drawings[n] = FaceDrawing(scheme_for(n))
        self._drawings[n].draw(image, faces, K)
        return image

    def _can_draw(self, image: np.ndarray) -> bool:
        """Whether the glasses can be drawn on frames of this size (an OpenGL context)."""
        if not self.glasses_problem:
            try:
                self.overlay.renderer(image.shape[1], image.shape[0])
            except Exception as exc:  # moderngl raises plain Exception when no context
                self.glasses_problem = f"no OpenGL context ({exc}): the glasses are not drawn"
        return not self.glasses_problem

    def close(self) -> None:
        """Free the renderers and the GL context."""
        self.overlay.close()

    def __enter__(self) -> Annotator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
