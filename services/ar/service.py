"""The glasses AR service: draws 3D glasses on each frame with its head pose (thesis ch. 15).

``aamtrack service ar [--jpeg Q] [--all-poses]``

For each reliable ``HeadPose`` the service takes the frame it belongs to
(the latest few frames are kept), renders the glasses with
:class:`~aamcore.ar.renderer.GlassesRenderer` at the pose and intrinsics of
the message, with the head hiding what lies behind it, and publishes the
result as an ``Overlay`` (raw, or JPEG with ``--jpeg``). The OpenGL (EGL)
context is created in the thread that renders, the service's main thread. A
pose whose frame is no longer kept is counted as dropped.
"""

from __future__ import annotations

import argparse
import collections
import threading
import time
from typing import Any

import cv2
import moderngl
import numpy as np

from aamcore.ar.renderer import GlassesRenderer
from proto import Frame, HeadPose, Overlay, ProtoError
from services.bus.runtime import BusOptions, Service, image_of, init_process, service_parser

NAME = "ar"
FRAMES_KEPT = 8


def build_parser() -> argparse.ArgumentParser:
    parser = service_parser(NAME, "Draw 3D glasses on each frame at the estimated head pose.")
    parser.add_argument("--jpeg", type=int, default=0, metavar="Q",
                        help="publish overlays as JPEG of quality Q (default raw)")
    parser.add_argument("--all-poses", action="store_true",
                        help="draw unreliable poses too")
    parser.add_argument("--capacity", type=int, default=2, help="latest poses kept while busy")
    parser.add_argument("--backend", default="egl", help="moderngl standalone backend")
    return parser


class RecentFrames:
    """The last :data:`FRAMES_KEPT` frames by index, fed by a Zenoh callback."""

    def __init__(self, svc: Service) -> None:
        self.svc = svc
        self._frames: collections.OrderedDict[int, Frame] = collections.OrderedDict()
        self._lock = threading.Lock()

    def on_frame(self, sample: Any) -> None:
        frame = self.svc.decode(sample.payload.to_bytes(), "frame", source="frame")
        if frame is None:
            return
        with self._lock:
            self._frames[frame.header.frame_index] = frame
            while len(self._frames) > FRAMES_KEPT:
                self._frames.popitem(last=False)

    def take(self, index: int) -> Frame | None:
        with self._lock:
            return self._frames.pop(index, None)


def bgr_image(frame: Frame) -> np.ndarray:
    """The frame's pixels as a contiguous ``(H, W, 3)`` BGR uint8 array."""
    image = image_of(frame)
    if image.ndim == 2:
        return cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
    return np.ascontiguousarray(image)


class Compositor:
    """Renderers per frame size, all in the GL context of the calling thread."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx
        self._renderers: dict[tuple[int, int], GlassesRenderer] = {}

    def render(self, image: np.ndarray, pose: HeadPose) -> np.ndarray:
        h, w = image.shape[:2]
        renderer = self._renderers.get((w, h))
        if renderer is None:
            renderer = self._renderers[(w, h)] = GlassesRenderer(w, h, self.ctx)
        return renderer.render(image, pose.rotation, pose.translation_mm, pose.intrinsics)

    def release(self) -> None:
        for renderer in self._renderers.values():
            renderer.release()
        self._renderers.clear()


def overlay_message(svc: Service, pose: HeadPose, image: np.ndarray, jpeg: int) -> Overlay:
    """The overlay of ``image`` (H, W, 3) for the frame of ``pose``."""
    header = svc.header(pose.header.frame_index, pose.header.capture_time_ns)
    if jpeg <= 0:
        return Overlay.from_array(header, image)
    ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, jpeg])
    if not ok:
        raise ProtoError("overlay: JPEG encoding failed")
    return Overlay.from_jpeg(header, data.tobytes(), image.shape[1], image.shape[0])


def serve(svc: Service, compositor: Compositor, args: argparse.Namespace) -> None:
    """Render overlays until stopped."""
    frames = RecentFrames(svc)
    svc.subscribe(svc.key("frame"), frames.on_frame)
    poses = svc.inbox("pose", capacity=args.capacity)
    svc.ready(f"renderer {compositor.ctx.info.get('GL_RENDERER', '?')}")
    unreliable = 0
    while not svc.stopping:
        got = poses.get(timeout=0.5)
        if got is None:
            continue
        pose = got.message
        assert isinstance(pose, HeadPose)
        if not (pose.reliable or args.all_poses):
            unreliable += 1
            continue
        frame = frames.take(pose.header.frame_index)
        if frame is None:
            svc.stats.dropped += 1  # its frame is gone: never received or pushed out
            continue
        started = time.perf_counter()
        try:
            image = bgr_image(frame)
            if (pose.image_width, pose.image_height) != (image.shape[1], image.shape[0]):
                raise ProtoError(f"pose for a {pose.image_width} x {pose.image_height} image, "
                                 f"frame is {image.shape[1]} x {image.shape[0]}")
            message = overlay_message(svc, pose, compositor.render(image, pose), args.jpeg)
        except (ProtoError, ValueError) as exc:
            svc.reject("pose", f"no overlay: {exc}")
            continue
        svc.publish(message)
        svc.stats.latency.add(1000 * (time.perf_counter() - started))
        svc.set_state("running", f"{unreliable} unreliable poses not drawn")


def run(args: argparse.Namespace) -> int:
    """Run the AR service with parsed arguments; the exit code."""
    log = init_process(NAME, args.verbose)
    try:
        ctx = moderngl.create_standalone_context(backend=args.backend)
    except Exception as exc:  # moderngl raises plain Exception when no context can be made
        log.error("no OpenGL context (backend %s): %s", args.backend, exc)
        return 1
    compositor = Compositor(ctx)
    try:
        with Service(NAME, BusOptions.from_args(args)) as svc:
            serve(svc, compositor, args)
    finally:
        compositor.release()
        ctx.release()
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point: ``python -m services.ar.service``."""
    return run(build_parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
