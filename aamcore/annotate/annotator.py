"""The annotator: the glasses by the AR renderer, then the 2D drawing, frame by frame."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from aamcore.annotate.draw import FaceDrawing
from aamcore.face_result import FaceResult
from aamcore.io.landmarks import scheme_for


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
        self._ctx: Any = None
        self._renderers: dict[tuple[int, int], Any] = {}
        self._drawings: dict[int, FaceDrawing] = {}
        """By number of landmarks: the colours of each scheme worked out once."""

    def draw(self, frame: np.ndarray, faces: Sequence[FaceResult], K: np.ndarray | None
             ) -> np.ndarray:
        """``frame`` (BGR uint8) with ``faces`` drawn on it, a new image; ``K`` the camera
        matrix of their poses (None: neither axes nor glasses)."""
        image = np.array(frame, dtype=np.uint8, copy=True)
        if image.ndim == 2:
            image = np.repeat(image[:, :, None], 3, axis=2)
        if K is not None and self.glasses:
            for face in faces:
                if face.pose_reliable and face.rotation is not None:
                    renderer = self._renderer(image.shape[1], image.shape[0])
                    if renderer is None:
                        break
                    image = renderer.render(image, face.rotation, face.translation_mm, K)
        n = next((len(f.landmarks) for f in faces if len(f.landmarks)), 0)
        if n not in self._drawings:
            self._drawings[n] = FaceDrawing(scheme_for(n))
        self._drawings[n].draw(image, faces, K)
        return image

    def _renderer(self, width: int, height: int) -> Any:
        if self.glasses_problem:
            return None
        renderer = self._renderers.get((width, height))
        if renderer is not None:
            return renderer
        try:
            import moderngl

            from aamcore.ar.renderer import GlassesRenderer

            if self._ctx is None:
                self._ctx = moderngl.create_standalone_context(backend="egl")
            renderer = self._renderers[(width, height)] = GlassesRenderer(width, height,
                                                                          self._ctx)
        except Exception as exc:  # moderngl raises plain Exception when no context can be made
            self.glasses_problem = f"no OpenGL context ({exc}): the glasses are not drawn"
            return None
        return renderer

    def close(self) -> None:
        """Free the renderers and the GL context."""
        for renderer in self._renderers.values():
            renderer.release()
        self._renderers.clear()
        if self._ctx is not None:
            self._ctx.release()
            self._ctx = None

    def __enter__(self) -> Annotator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

