"""The overlay stage: 3D glasses drawn on a frame at the head pose of each of its faces
(thesis ch. 15), the head hiding what lies behind it and a hand or an object in front of
the face (its covered landmarks, :mod:`aamcore.ar.cover`) hiding the glasses."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from aamcore.ar.cover import cover_mask, cover_radius
from aamcore.operators.faces import FacePose
from aamcore.operators.options import PIPELINE, OverlayOptions


class OverlayOperator:
    """Draw the glasses of a frame's poses (a :class:`~aamcore.ar.renderer.GlassesRenderer`
    per frame size, in one OpenGL context: every call from the thread that made it).

    Parameters
    ----------
    options : OverlayOptions
    ctx : moderngl.Context, optional
        The context to draw in; made (headless EGL) at the first drawing if None, and
        released by :meth:`close`.
    """

    def __init__(self, options: OverlayOptions = PIPELINE.overlay, ctx: Any = None) -> None:
        self.options = options
        self.ctx = ctx
        self._own = ctx is None
        self._renderers: dict[tuple[int, int], Any] = {}

    def draws(self, pose: FacePose) -> bool:
        """Whether the glasses are drawn at ``pose``: a reliable one (any, with
        ``all_poses``)."""
        return pose.found and (pose.reliable or self.options.all_poses)

    def __call__(self, image: np.ndarray, poses: Sequence[FacePose]) -> np.ndarray:
        """``image`` ((H, W, 3) BGR uint8) with the glasses of every pose drawn
        (:meth:`draws`), a new image; where a pose's ``covered`` landmarks say a hand or an
        object covers the face, the frame shows through.

        Raises
        ------
        Exception
            When no OpenGL context can be made (moderngl raises a plain ``Exception``).
        """
        out = np.array(image, np.uint8, copy=True)
        for pose in poses:
            if self.draws(pose):
                renderer = self.renderer(out.shape[1], out.shape[0])
                drawn = renderer.render(out, pose.rotation, pose.translation_mm, pose.K)
                covered = self.covered(pose, out.shape[:2])
                if covered is not None:
                    np.copyto(drawn, out, where=covered[..., None])
                out = drawn
        return out

    def covered(self, pose: FacePose, shape: tuple[int, int]) -> np.ndarray | None:
        """The pixels (H, W) bool where something in front of the face of ``pose`` hides
        its glasses (None: nothing, or ``hide_covered`` off)."""
        if not self.options.hide_covered or pose.covered is None or not len(pose.covered):
            return None
        return cover_mask(pose.covered, shape, cover_radius(pose.K, pose.translation_mm))

    def renderer(self, width: int, height: int) -> Any:
        """The renderer of frames of ``width`` x ``height`` (made, with the context, at the
        first call).

        Raises
        ------
        Exception
            When no OpenGL context can be made.
        """
        renderer = self._renderers.get((width, height))
        if renderer is None:
            from aamcore.ar.renderer import GlassesRenderer

            if self.ctx is None:
                import moderngl

                self.ctx = moderngl.create_standalone_context(backend="egl")
            renderer = self._renderers[(width, height)] = GlassesRenderer(width, height,
                                                                          self.ctx)
        return renderer

    def close(self) -> None:
        """Free the renderers (and the context, if this operator made it)."""
        for renderer in self._renderers.values():
            renderer.release()
        self._renderers.clear()
        if self._own and self.ctx is not None:
            self.ctx.release()
            self.ctx = None
