"""The piecewise-affine warp done by OpenGL (thesis appendix B).

:class:`GLWarp` draws the reference frame's triangles into a framebuffer of
the reference size. Each vertex sits at its mean-shape position in the frame
and carries, as texture coordinates, the landmark it maps to in the image; the
rasteriser interpolates those coordinates affinely across each triangle and
the texture unit samples the image bilinearly. The framebuffer is read back
and the inside pixels gathered into the same ``(M, C)`` layout as
:meth:`aamcore.warp.piecewise_affine.PiecewiseAffineWarp.warp`.

Conventions that make the two warps agree:

- OpenCV puts pixel centres at integer coordinates, OpenGL at half-integers
  (in window coordinates and in texels). A frame pixel ``(x, y)`` is drawn at
  window position ``(x + 0.5, y + 0.5)`` and an image position ``(u, v)`` is
  sampled at texture coordinate ``((u + 0.5) / W, (v + 0.5) / H)``.
- Rows are not flipped: image row 0 is uploaded first (texture ``t`` near 0)
  and frame row 0 is drawn at the bottom of the framebuffer, which is the row
  ``glReadPixels`` returns first.
- Clamp-to-edge sampling repeats the border like ``cv2.BORDER_REPLICATE``.

The rasteriser fills a pixel only when its centre is strictly inside a
triangle (or on a top-left edge), while the CPU frame also keeps pixels whose
centres lie on the outline. Which pixels the exact triangles miss depends on
the reference geometry alone, so it is found once, when the warp is built,
by drawing a white image. The triangles owning a missed pixel are then also
drawn grown about their centroids by :data:`EDGE_GROWTH` pixels, with texture
coordinates extrapolated by the same affine map, before the exact triangles,
which paint over them everywhere but on the missed outline pixels. Coverage
of every frame pixel is checked again after that.

The GL texture unit blends with 8-bit fractional weights and ``cv2.remap``
with 5-bit ones (1/32 pixel), so the two differ by a fraction of a grey
level on average (``tests/gl/test_gl_warp.py`` and ``bench/bench_gl_warp.py``
measure it).
"""

from __future__ import annotations

import moderngl
import numpy as np

from aamcore.warp.reference_frame import ReferenceFrame

EDGE_GROWTH = 1.0 / 32.0
"""Pixels by which every edge of the outline-filling triangles moves outward.

More than the rasteriser's sub-pixel snapping (1/256 px on common hardware and
in llvmpipe), small enough that the extrapolated texture coordinates stay
within a few hundredths of a pixel of the exact ones."""

_VERTEX_SHADER = """
#version 330
uniform vec2 frame_size;
uniform vec2 image_size;
in vec2 in_ref;
in vec2 in_src;
out vec2 v_uv;
void main() {
    gl_Position = vec4((in_ref + 0.5) / frame_size * 2.0 - 1.0, 0.0, 1.0);
    v_uv = (in_src + 0.5) / image_size;
}
"""

_FRAGMENT_SHADER = """
#version 330
uniform sampler2D image;
in vec2 v_uv;
out vec4 colour;
void main() {
    colour = texture(image, v_uv);
}
"""


def grown_triangle_weights(
    vertices: np.ndarray, triangles: np.ndarray, n_points: int, growth: float
) -> np.ndarray:
    """Landmark weights (3T, n_points) and positions of triangles grown about their centroids.

    Row ``3t + k`` gives vertex ``k`` of triangle ``t`` scaled about the
    centroid so that each edge moves outward by at least ``growth`` pixels,
    written as a combination of the triangle's three landmarks: its image
    position is ``weights @ shape``. With ``growth=0`` the rows select the
    triangle's own landmarks.

    Parameters
    ----------
    vertices : (N, 2) array
        Triangle vertices in frame pixels.
    triangles : (T, 3) int array
    n_points : int
    growth : float
        Pixels, >= 0.

    Returns
    -------
    weights : (3T, n_points) float64 array
    positions : (3T, 2) float64 array
        The grown vertices in frame pixels (``weights @ vertices``).
    """
    corners = vertices[triangles]  # (T, 3, 2)
    centroid = corners.mean(axis=1)
    edge = np.roll(corners, -1, axis=1) - corners
    rel = centroid[:, None, :] - corners
    cross = np.abs(edge[..., 0] * rel[..., 1] - edge[..., 1] * rel[..., 0])
    distance = cross / np.linalg.norm(edge, axis=2)  # centroid to each edge, (T, 3)
    k = growth / distance.min(axis=1)
    # A vertex scaled by (1 + k) about the centroid has barycentric
    # coordinates (1 + 2k/3, -k/3, -k/3) in its own triangle.
    n_tri = len(triangles)
    weights = np.zeros((3 * n_tri, n_points))
    rows = np.arange(3 * n_tri).reshape(n_tri, 3)
    for own in range(3):
        for other in range(3):
            w = 1.0 + 2.0 * k / 3.0 if own == other else -k / 3.0
            np.add.at(weights, (rows[:, own], triangles[:, other]), w)
    return weights, weights @ vertices


def _check_image(image: np.ndarray) -> np.ndarray:
    image = np.asarray(image)
    if image.dtype != np.uint8:
        raise ValueError(f"GL warp needs a uint8 image, got {image.dtype}")
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[..., 0]
    if not (image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)):
        raise ValueError(f"GL warp needs a grey (H, W) or BGR (H, W, 3) image, got {image.shape}")
    if min(image.shape[:2]) < 1:
        raise ValueError(f"empty image of shape {image.shape}")
    return np.ascontiguousarray(image)


class GLWarp:
    """Piecewise-affine warp of images into a :class:`ReferenceFrame`, by OpenGL.

    Parameters
    ----------
    frame : ReferenceFrame
    n_points : int
        Number of landmarks.
    ctx : moderngl.Context
        A context current in the calling thread; every method must be called
        from that thread.
    edge_growth : float
        Growth of the outline-filling triangles in pixels (0 draws only the
        exact triangles, which leaves outline pixels unpainted).

    Attributes
    ----------
    n_grown : int
        Triangles also drawn grown to fill outline pixels the exact ones miss.

    Raises
    ------
    RuntimeError
        If the drawn triangles leave a frame pixel uncovered (checked once).
    """

    def __init__(
        self,
        frame: ReferenceFrame,
        n_points: int,
        ctx: moderngl.Context,
        edge_growth: float = EDGE_GROWTH,
    ) -> None:
        if frame.triangles.max() >= n_points:
            raise ValueError(
                f"the frame's triangles use landmark {frame.triangles.max()} but n_points is "
                f"{n_points}"
            )
        self.frame = frame
        self.n_points = n_points
        self.ctx = ctx
        height, width = frame.size
        self._program = ctx.program(vertex_shader=_VERTEX_SHADER, fragment_shader=_FRAGMENT_SHADER)
        self._program["frame_size"].value = (float(width), float(height))
        self._colour = ctx.renderbuffer((width, height), components=4)
        self._fbo = ctx.framebuffer(color_attachments=[self._colour])
        self._texture: moderngl.Texture | None = None
        self._channels = 0
        self._read = {c: np.empty((height * width, c), dtype=np.uint8) for c in (1, 3)}
        xy = frame.pixels.astype(np.int64)
        self._gather = xy[:, 1] * width + xy[:, 0]
        self._vao: moderngl.VertexArray | None = None
        self._buffers: list[moderngl.Buffer] = []
        exact, exact_pos = grown_triangle_weights(frame.vertices, frame.triangles, n_points, 0.0)
        self._load_geometry(exact, exact_pos)
        missed = self._unpainted()
        self.n_grown = 0
        if missed.size and edge_growth > 0:
            # Only triangles owning a missed pixel need a grown copy, drawn
            # first so the exact triangles paint over it everywhere else.
            which = np.unique(frame.pixel_triangle[missed])
            grown, grown_pos = grown_triangle_weights(
                frame.vertices, frame.triangles[which], n_points, edge_growth
            )
            self._load_geometry(np.vstack([grown, exact]), np.vstack([grown_pos, exact_pos]))
            self.n_grown = len(which)
            missed = self._unpainted()
        if missed.size:
            self.release()
            raise RuntimeError(
                f"GL warp leaves {missed.size} of {self.n_pixels} frame pixels unpainted"
            )
        self._texture.release()  # the white test image
        self._texture, self._channels = None, 0

    @property
    def n_pixels(self) -> int:
        return self.frame.n_pixels

    @property
    def renderer(self) -> str:
        """The OpenGL renderer string (e.g. ``llvmpipe`` or a GPU's name)."""
        return str(self.ctx.info["GL_RENDERER"])

    def upload(self, image: np.ndarray) -> None:
        """Load ``image`` (H, W) grey or (H, W, 3) BGR uint8 as the texture to sample.

        The texture object is reused while the size and channel count stay the same.
        """
        image = _check_image(image)
        channels = 1 if image.ndim == 2 else 3
        height, width = image.shape[:2]
        tex = self._texture
        if tex is None or tex.size != (width, height) or tex.components != channels:
            if tex is not None:
                tex.release()
            tex = self.ctx.texture((width, height), channels, image, alignment=1)
            tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
            tex.repeat_x = False  # clamp to edge, as cv2.BORDER_REPLICATE
            tex.repeat_y = False
            self._texture = tex
            self._program["image_size"].value = (float(width), float(height))
        else:
            tex.write(image, alignment=1)
        self._channels = channels

    def warp(self, shape: np.ndarray) -> np.ndarray:
        """Texture of the uploaded image inside ``shape`` (N, 2) image pixels.

        Returns
        -------
        (M, C) float32 array for a BGR image, (M,) for a grey one, like
        :meth:`aamcore.warp.piecewise_affine.PiecewiseAffineWarp.warp`.
        """
        if self._texture is None:
            raise RuntimeError("no image uploaded: call upload(image) before warp(shape)")
        shape = np.asarray(shape, dtype=np.float32)
        if shape.shape != (self.n_points, 2):
            raise ValueError(f"shape must be ({self.n_points}, 2), got {shape.shape}")
        if not np.all(np.isfinite(shape)):
            raise ValueError("shape has NaN or infinite coordinates")
        self._src_buffer.write(self._weights @ shape)
        self._draw()
        out = self._read[self._channels]
        self._fbo.read_into(out, components=self._channels, alignment=1)
        texture = np.take(out, self._gather, axis=0).astype(np.float32)
        return texture[:, 0] if self._channels == 1 else texture

    def warp_image(self, image: np.ndarray, shape: np.ndarray) -> np.ndarray:
        """Upload ``image`` and warp it: ``upload(image)`` then ``warp(shape)``."""
        self.upload(image)
        return self.warp(shape)

    def release(self) -> None:
        """Free the GL objects (the context stays with its owner)."""
        for obj in (self._vao, *self._buffers, self._fbo, self._colour, self._program,
                    self._texture):
            if obj is not None:
                obj.release()
        self._vao, self._buffers, self._texture = None, [], None

    def _load_geometry(self, weights: np.ndarray, positions: np.ndarray) -> None:
        """Use triangle vertices at ``positions`` (V, 2) sampling ``weights @ shape``."""
        if self._vao is not None:
            self._vao.release()
        for buffer in self._buffers:
            buffer.release()
        self._weights = weights.astype(np.float32)
        positions = positions.astype(np.float32)
        ref = self.ctx.buffer(positions.tobytes())
        self._src_buffer = self.ctx.buffer(reserve=positions.nbytes)
        self._buffers = [ref, self._src_buffer]
        self._vao = self.ctx.vertex_array(
            self._program, [(ref, "2f", "in_ref"), (self._src_buffer, "2f", "in_src")]
        )

    def _draw(self) -> None:
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE | moderngl.BLEND)
        self._fbo.use()
        self._texture.use(0)
        self._program["image"].value = 0
        self._vao.render(moderngl.TRIANGLES)

    def _unpainted(self) -> np.ndarray:
        """Indices (K,) of frame pixels the current triangles leave unpainted."""
        self.upload(np.full((2, 2), 255, dtype=np.uint8))
        self._fbo.clear()
        self._src_buffer.write(self._weights @ np.zeros((self.n_points, 2), dtype=np.float32))
        self._draw()
        out = self._read[1]
        self._fbo.read_into(out, components=1, alignment=1)
        return np.flatnonzero(out[self._gather, 0] != 255)
