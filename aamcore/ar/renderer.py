"""OpenGL renderer compositing 3D glasses over a video frame (thesis section 15.2).

Each frame is drawn in three passes into one framebuffer of the frame's size:

1. the video frame itself, as the background (no depth);
2. the head (:mod:`aamcore.ar.head_occluder`) into the depth buffer only,
   colour writes off, so whatever lies behind the head fails the depth test;
3. the glasses: the frame, bridge and temples opaque with simple shading
   (ambient, Lambert and a Blinn-Phong highlight, lit from near the camera),
   then the lenses as a translucent tint, blended and not written to depth.

The projection comes from the camera matrix ``K`` as set out in
:mod:`aamcore.ar.projection` (OpenCV axes kept, no image flip). Colours are
BGR throughout, like the frames. Multisampling smooths the glasses' edges
where the context offers it.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import moderngl
import numpy as np

from aamcore.ar.glasses_mesh import LENS_PARTS, OPAQUE_PARTS, GlassesMesh, mean_head_glasses
from aamcore.ar.head_occluder import HeadOccluder, mean_head_occluder
from aamcore.ar.mesh_primitives import TriMesh
from aamcore.ar.projection import pose_matrix, projection_from_intrinsics

_BACKGROUND_VS = """
#version 330
const vec2 corners[4] = vec2[](vec2(-1.0, -1.0), vec2(1.0, -1.0), vec2(-1.0, 1.0), vec2(1.0, 1.0));
void main() {
    gl_Position = vec4(corners[gl_VertexID], 0.0, 1.0);
}
"""

_BACKGROUND_FS = """
#version 330
uniform sampler2D frame;
out vec4 colour;
void main() {
    colour = texelFetch(frame, ivec2(gl_FragCoord.xy), 0);
}
"""

_MESH_VS = """
#version 330
uniform mat4 projection;
uniform mat4 pose;
in vec3 in_position;
in vec3 in_normal;
out vec3 v_position;
out vec3 v_normal;
void main() {
    vec4 camera = pose * vec4(in_position, 1.0);
    v_position = camera.xyz;
    v_normal = mat3(pose) * in_normal;
    gl_Position = projection * camera;
}
"""

_MESH_FS = """
#version 330
uniform vec3 colour;
uniform float alpha;
uniform float shading;
uniform vec3 light;
in vec3 v_position;
in vec3 v_normal;
out vec4 frag;
void main() {
    vec3 n = normalize(v_normal);
    vec3 v = normalize(-v_position);
    if (dot(n, v) < 0.0) {
        n = -n;  // two-sided lighting
    }
    vec3 l = normalize(light);
    float diffuse = max(dot(n, l), 0.0);
    float highlight = pow(max(dot(n, normalize(l + v)), 0.0), 40.0);
    vec3 lit = colour * (0.35 + 0.65 * diffuse) + vec3(0.6 * highlight);
    frag = vec4(mix(colour, lit, shading), alpha);
}
"""

FRAME_COLOUR = (0.12, 0.12, 0.14)
"""Glasses frame colour, BGR in 0-1: near-black."""
LENS_COLOUR = (0.55, 0.35, 0.2)
"""Lens tint, BGR in 0-1: blue-grey."""
LENS_ALPHA = 0.3
LIGHT = (-0.3, -0.5, -1.0)
"""Direction toward the light, camera frame (OpenCV axes): above-left of the camera."""


def _is_software(ctx: moderngl.Context) -> bool:
    renderer = str(ctx.info.get("GL_RENDERER", "")).lower()
    return any(name in renderer for name in ("llvmpipe", "softpipe", "swrast", "software"))


def _set_masks(fbo: moderngl.Framebuffer, colour: bool, depth: bool) -> None:
    """Turn colour and depth writes on or off (moderngl applies masks on ``use``)."""
    fbo.color_mask = (colour,) * 4
    fbo.depth_mask = depth
    fbo.use()


class _MeshBuffers:
    """A mesh's vertex, normal and index buffers with a vertex array for ``program``."""

    def __init__(self, ctx: moderngl.Context, program: moderngl.Program, mesh: TriMesh) -> None:
        self._buffers = [
            ctx.buffer(mesh.vertices.tobytes()),
            ctx.buffer(mesh.normals.tobytes()),
            ctx.buffer(mesh.triangles.tobytes()),
        ]
        self.vao = ctx.vertex_array(
            program,
            [(self._buffers[0], "3f", "in_position"), (self._buffers[1], "3f", "in_normal")],
            index_buffer=self._buffers[2],
            index_element_size=4,
        )

    def draw(self, first_triangle: int, n_triangles: int) -> None:
        self.vao.render(moderngl.TRIANGLES, vertices=3 * n_triangles, first=3 * first_triangle)

    def release(self) -> None:
        self.vao.release()
        for buffer in self._buffers:
            buffer.release()


class GlassesRenderer:
    """Draw glasses on the head in video frames of one size.

    Parameters
    ----------
    width, height : int
        Frame size in pixels.
    ctx : moderngl.Context
        A context current in the calling thread; all calls must come from it.
    glasses : GlassesMesh, optional
        Default: :func:`aamcore.ar.glasses_mesh.mean_head_glasses`.
    head : HeadOccluder, optional
        Default: :func:`aamcore.ar.head_occluder.mean_head_occluder`.
    samples : int, optional
        Multisampling samples, limited to what the context offers; 0 for none.
        By default 4 on a GPU and none on a software rasteriser (llvmpipe),
        where 4 samples cost about 18 ms a 640x480 frame.
    near, far : float
        Depth range in mm.
    """

    def __init__(
        self,
        width: int,
        height: int,
        ctx: moderngl.Context,
        glasses: GlassesMesh | None = None,
        head: HeadOccluder | None = None,
        samples: int | None = None,
        near: float = 10.0,
        far: float = 10_000.0,
    ) -> None:
        if width < 1 or height < 1:
            raise ValueError(f"frame size must be positive, got {width}x{height}")
        self.width, self.height = int(width), int(height)
        self.ctx = ctx
        self.near, self.far = near, far
        self.glasses = glasses or mean_head_glasses()
        self.head = head or mean_head_occluder()
        size = (self.width, self.height)
        if samples is None:
            samples = 0 if _is_software(ctx) else 4
        self.samples = min(max(int(samples), 0), ctx.max_samples)
        self._background = ctx.program(vertex_shader=_BACKGROUND_VS, fragment_shader=_BACKGROUND_FS)
        self._background_vao = ctx.vertex_array(self._background, [])
        self._program = ctx.program(vertex_shader=_MESH_VS, fragment_shader=_MESH_FS)
        self._program["light"].value = LIGHT
        self._glasses_buffers = _MeshBuffers(ctx, self._program, self.glasses.mesh)
        self._head_buffers = _MeshBuffers(ctx, self._program, self.head.mesh)
        self._frame_texture = ctx.texture(size, 3, alignment=1)
        self._frame_texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._targets = [
            ctx.renderbuffer(size, components=4, samples=self.samples),
            ctx.depth_renderbuffer(size, samples=self.samples),
        ]
        self._draw_fbo = ctx.framebuffer(self._targets[0], self._targets[1])
        self._resolved = None
        if self.samples:
            self._targets.append(ctx.renderbuffer(size, components=4))
            self._resolved = ctx.framebuffer(self._targets[-1])
        self._plain_targets = [
            ctx.renderbuffer(size, components=4),
            ctx.depth_renderbuffer(size),
        ]
        self._plain_fbo = ctx.framebuffer(self._plain_targets[0], self._plain_targets[1])
        self._out = np.empty((self.height, self.width, 3), dtype=np.uint8)
        lo, hi = self.glasses.mesh.vertices.min(axis=0), self.glasses.mesh.vertices.max(axis=0)
        self._corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                                  for z in (lo[2], hi[2])], np.float64)

    def render(
        self, frame: np.ndarray, R: np.ndarray, T: np.ndarray, K: np.ndarray
    ) -> np.ndarray:
        """The frame with the glasses drawn on the head at pose ``(R, T)``.

        Parameters
        ----------
        frame : (H, W, 3) uint8 array
            BGR video frame of the renderer's size.
        R : (3, 3) array
            Rotation taking head-model points to the camera frame (OpenCV axes).
        T : (3,) array
            Translation in mm: ``X_cam = R X + T``.
        K : (3, 3) array
            Camera matrix, pixels.

        Returns
        -------
        (H, W, 3) uint8 array
            A new BGR image.
        """
        frame = self._check_frame(frame)
        out = frame.copy()
        box = self._glasses_box(R, T, K)
        if box is None:  # the glasses lie outside the frame: nothing to draw
            return out
        x0, y0, x1, y1 = box
        viewport = (x0, y0, x1 - x0, y1 - y0)
        self._set_camera(R, T, K)
        # only the glasses' box is uploaded, drawn and read back (frame row y is GL row y):
        # the rest of the frame is the frame itself
        self._frame_texture.write(np.ascontiguousarray(frame[y0:y1, x0:x1]), viewport=viewport,
                                  alignment=1)
        fbo = self._draw_fbo
        fbo.use()
        fbo.scissor = viewport
        fbo.clear(depth=1.0, viewport=viewport)
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE | moderngl.BLEND)
        self._frame_texture.use(0)
        self._background["frame"].value = 0
        self._background_vao.render(moderngl.TRIANGLE_STRIP, vertices=4)
        self.ctx.enable(moderngl.DEPTH_TEST)
        self._draw_head(fbo)
        self._draw_parts(OPAQUE_PARTS, FRAME_COLOUR, 1.0, shading=1.0)
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        _set_masks(fbo, colour=True, depth=False)
        self._draw_parts(LENS_PARTS, LENS_COLOUR, LENS_ALPHA, shading=1.0)
        _set_masks(fbo, colour=True, depth=True)
        self.ctx.disable(moderngl.BLEND)
        fbo.scissor = None
        if self._resolved is not None:
            self.ctx.copy_framebuffer(self._resolved, fbo)
            fbo = self._resolved
        read = self._out.reshape(-1)[:(y1 - y0) * (x1 - x0) * 3]
        fbo.read_into(read, viewport=viewport, components=3, alignment=1)
        out[y0:y1, x0:x1] = read.reshape(y1 - y0, x1 - x0, 3)
        return out

    def _glasses_box(self, R: np.ndarray, T: np.ndarray, K: np.ndarray
                     ) -> tuple[int, int, int, int] | None:
        """The pixels ``(x0, y0, x1, y1)`` the glasses may cover (their 3D box projected, a
        pixel or two around it, within the frame; all of it where a corner lies behind the
        camera), None when none lies in the frame."""
        cam = self._corners @ np.asarray(R, np.float64).T + np.asarray(T, np.float64)
        if np.any(cam[:, 2] <= self.near):
            return 0, 0, self.width, self.height
        uv = cam @ np.asarray(K, np.float64).T
        uv = uv[:, :2] / uv[:, 2:]
        x0, y0 = np.floor(uv.min(axis=0)).astype(int) - 2
        x1, y1 = np.ceil(uv.max(axis=0)).astype(int) + 3
        x0, y0 = max(int(x0), 0), max(int(y0), 0)
        x1, y1 = min(int(x1), self.width), min(int(y1), self.height)
        if x1 <= x0 or y1 <= y0:
            return None
        return x0, y0, x1, y1

    def coverage(
        self,
        R: np.ndarray,
        T: np.ndarray,
        K: np.ndarray,
        parts: Iterable[str] | None = None,
        occlude: bool = True,
    ) -> np.ndarray:
        """Pixels (H, W) bool where the named glasses parts are visible (all parts by default).

        With ``occlude=False`` the head is left out and nothing hides the glasses.
        """
        names = tuple(OPAQUE_PARTS + LENS_PARTS if parts is None else parts)
        unknown = [n for n in names if n not in self.glasses.parts]
        if unknown:
            raise ValueError(f"unknown glasses parts {unknown}; known: {list(self.glasses.parts)}")
        self._set_camera(R, T, K)
        fbo = self._plain_fbo
        fbo.use()
        fbo.clear(depth=1.0)
        self.ctx.disable(moderngl.CULL_FACE | moderngl.BLEND)
        self.ctx.enable(moderngl.DEPTH_TEST)
        if occlude:
            self._draw_head(fbo)
        self._draw_parts(names, (1.0, 1.0, 1.0), 1.0, shading=0.0)
        mask = np.empty((self.height, self.width), dtype=np.uint8)
        fbo.read_into(mask, components=1, alignment=1)
        return mask > 0

    def release(self) -> None:
        """Free the GL objects (the context stays with its owner)."""
        self._glasses_buffers.release()
        self._head_buffers.release()
        for obj in (self._background_vao, self._background, self._program, self._frame_texture,
                    self._draw_fbo, self._resolved, self._plain_fbo, *self._targets,
                    *self._plain_targets):
            if obj is not None:
                obj.release()

    def _check_frame(self, frame: np.ndarray) -> np.ndarray:
        frame = np.asarray(frame)
        expected = (self.height, self.width, 3)
        if frame.dtype != np.uint8 or frame.shape != expected:
            raise ValueError(
                f"frame must be a uint8 BGR image of shape {expected}, got {frame.dtype} "
                f"{frame.shape}"
            )
        return np.ascontiguousarray(frame)

    def _set_camera(self, R: np.ndarray, T: np.ndarray, K: np.ndarray) -> None:
        P = projection_from_intrinsics(K, self.width, self.height, self.near, self.far)
        M = pose_matrix(R, T)
        # GLSL matrices are column-major: pass the transposes' bytes.
        self._program["projection"].write(P.T.astype(np.float32).tobytes())
        self._program["pose"].write(M.T.astype(np.float32).tobytes())

    def _draw_head(self, fbo: moderngl.Framebuffer) -> None:
        _set_masks(fbo, colour=False, depth=True)
        self._head_buffers.draw(0, self.head.mesh.n_triangles)
        _set_masks(fbo, colour=True, depth=True)

    def _draw_parts(
        self, names: Sequence[str], colour: Sequence[float], alpha: float, shading: float
    ) -> None:
        self._program["colour"].value = tuple(colour)
        self._program["alpha"].value = alpha
        self._program["shading"].value = shading
        for name in names:
            first, count = self.glasses.parts[name]
            self._glasses_buffers.draw(first, count)
