"""Headless OpenGL rendering of the textured head (moderngl, EGL).

The projection reproduces OpenCV's pinhole model exactly: a camera point
``(x, y, z)`` lands where :meth:`CameraIntrinsics.project` puts it (pixel
centres at integer coordinates, row 0 on top). Distortion is not rendered.

A GL context belongs to the thread that created it: create the renderer in
the thread that renders, and never fork a process that holds one.
"""

from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.synth.head import SynthHead
from aamcore.synth.texture import FaceTexture

NEAR_MM, FAR_MM = 50.0, 5000.0

_VERTEX = """
#version 330
uniform mat4 mvp;
in vec3 in_position;
in vec2 in_uv;
out vec2 uv;
void main() {
    gl_Position = mvp * vec4(in_position, 1.0);
    uv = in_uv;
}
"""

_FRAGMENT = """
#version 330
uniform sampler2D tex;
in vec2 uv;
out vec4 colour;
void main() {
    colour = vec4(texture(tex, uv).rgb, 1.0);
}
"""


@dataclass(frozen=True, eq=False)
class Rendering:
    """One rendered frame.

    Attributes
    ----------
    image : (H, W, 3) uint8 array
        BGR, background ``background`` where the head is not.
    mask : (H, W) bool array
        True where the head covers the pixel.
    depth : (H, W) float64 array
        Camera z of the visible surface, mm; inf on the background.
    """

    image: np.ndarray
    mask: np.ndarray
    depth: np.ndarray


def opengl_projection(camera: CameraIntrinsics, near: float = NEAR_MM,
                      far: float = FAR_MM) -> np.ndarray:
    """The (4, 4) clip matrix for OpenCV camera coordinates (x right, y down, z forward).

    Window coordinates come out as ``(u + 0.5, v + 0.5)`` for the OpenCV pixel
    ``(u, v)``, with the window's first row being image row 0 (the framebuffer
    is read back top row first, so no flip is needed).
    """
    K, w, h = camera.K, camera.width, camera.height
    P = np.zeros((4, 4))
    P[0, 0] = 2.0 * K[0, 0] / w
    P[0, 1] = 2.0 * K[0, 1] / w
    P[0, 2] = 2.0 * (K[0, 2] + 0.5) / w - 1.0
    P[1, 1] = 2.0 * K[1, 1] / h
    P[1, 2] = 2.0 * (K[1, 2] + 0.5) / h - 1.0
    P[2, 2] = (far + near) / (far - near)
    P[2, 3] = -2.0 * far * near / (far - near)
    P[3, 2] = 1.0
    return P


class HeadRenderer:
    """Renders a :class:`SynthHead` with a :class:`FaceTexture` under given poses.

    Parameters
    ----------
    head : SynthHead
    texture : FaceTexture
    camera : CameraIntrinsics
        Image size and pinhole parameters (distortion is ignored).
    background : (3,) ints
        BGR colour of the background.
    samples : int
        Multisampling for anti-aliased edges (0 for none).

    Notes
    -----
    Creates its own EGL context: build and use it in one thread; call
    :meth:`close` (or use it as a context manager) to free the GPU objects.
    """

    def __init__(
        self,
        head: SynthHead,
        texture: FaceTexture,
        camera: CameraIntrinsics,
        background: tuple[int, int, int] = (90, 90, 90),
        samples: int = 4,
    ) -> None:
        if head.mesh.uvs is None:
            raise ValueError("the head mesh has no texture coordinates")
        self.camera = camera
        self.background = np.array(background, dtype=np.uint8)
        self.ctx = moderngl.create_standalone_context(backend="egl")
        size = (camera.width, camera.height)
        samples = min(samples, self.ctx.max_samples)
        self._msaa = self.ctx.framebuffer(
            self.ctx.renderbuffer(size, 4, samples=samples),
            self.ctx.depth_renderbuffer(size, samples=samples),
        )
        self._fbo = self.ctx.framebuffer(self.ctx.renderbuffer(size, 4),
                                         self.ctx.depth_texture(size))
        self._prog = self.ctx.program(vertex_shader=_VERTEX, fragment_shader=_FRAGMENT)
        tex_rgb = np.ascontiguousarray(texture.image[:, :, ::-1])
        self._tex = self.ctx.texture((tex_rgb.shape[1], tex_rgb.shape[0]), 3, tex_rgb.tobytes())
        self._tex.build_mipmaps()
        self._tex.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
        # Texture rows are uploaded top row first, so GL's t = 0 is the top: t = 1 - v.
        uv = head.mesh.uvs * [1.0, -1.0] + [0.0, 1.0]
        data = np.hstack([head.mesh.vertices, uv]).astype("f4")
        self._vbo = self.ctx.buffer(data.tobytes())
        self._ibo = self.ctx.buffer(head.mesh.triangles.astype("i4").tobytes())
        self._vao = self.ctx.vertex_array(
            self._prog, [(self._vbo, "3f 2f", "in_position", "in_uv")], self._ibo)
        self._projection = opengl_projection(camera)

    def render(self, R: np.ndarray, T: np.ndarray) -> Rendering:
        """Render the head under pose ``X_cam = R @ X_head + T`` (T in mm)."""
        view = np.eye(4)
        view[:3, :3], view[:3, 3] = R, T
        mvp = self._projection @ view
        self._prog["mvp"].write(mvp.T.astype("f4").tobytes())  # GL matrices are column-major
        self._msaa.use()
        self.ctx.enable(moderngl.DEPTH_TEST)
        self.ctx.disable(moderngl.CULL_FACE)
        self.ctx.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        self._tex.use(0)
        self._vao.render(moderngl.TRIANGLES)
        self.ctx.copy_framebuffer(self._fbo, self._msaa)
        w, h = self.camera.width, self.camera.height
        rgba = np.frombuffer(self._fbo.read(components=4), np.uint8).reshape(h, w, 4)
        mask = rgba[:, :, 3] > 127
        alpha = rgba[:, :, 3:4].astype(np.float32) / 255.0
        bgr = rgba[:, :, 2::-1].astype(np.float32) * alpha + self.background * (1.0 - alpha)
        image = np.clip(np.round(bgr), 0, 255).astype(np.uint8)
        return Rendering(image, mask, self._depth(mask))

    def _depth(self, mask: np.ndarray) -> np.ndarray:
        w, h = self.camera.width, self.camera.height
        d = np.frombuffer(self._fbo.depth_attachment.read(), np.float32).reshape(h, w)
        ndc = 2.0 * d.astype(np.float64) - 1.0
        z = 2.0 * FAR_MM * NEAR_MM / (FAR_MM + NEAR_MM - ndc * (FAR_MM - NEAR_MM))
        return np.where(d < 1.0, z, np.inf)

    def close(self) -> None:
        """Release the GL objects and the context."""
        for obj in (self._vao, self._vbo, self._ibo, self._tex, self._prog, self._fbo, self._msaa):
            obj.release()
        self.ctx.release()

    def __enter__(self) -> HeadRenderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
