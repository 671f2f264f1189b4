"""The glasses AR service: a thin adapter around the overlay stage's operator
(:class:`aamcore.operators.overlay.OverlayOperator`), 3D glasses on each frame at its head
pose (thesis ch. 15).

``aamtrack service ar [--jpeg Q] [--all-poses]``

For each reliable ``HeadPose`` the service takes the frame it belongs to
(frames are kept until a pose of a later frame comes,
:class:`services.bus.frames.FrameStore`; with several faces, the frame as drawn for its
faces so far, so that each overlay of a frame has the glasses of every face
drawn before it and the last has them all), renders the glasses at the pose and
intrinsics of the message, with the head hiding what lies behind it, and publishes the
result as an ``Overlay`` (raw, or JPEG with ``--jpeg``). The OpenGL (EGL)
context is created in the thread that renders, the service's main thread. A
pose whose frame is no longer kept is counted as dropped.
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import moderngl
import numpy as np

from aamcore.operators.overlay import OverlayOperator
from proto import Frame, HeadPose, Overlay, ProtoError
from services.ar.options import AROptions
from services.bus.args import parse_service_args
from services.bus.images import image_of
from services.bus.process import init_process
from services.bus.session import Service
from services.messages import pose_of

NAME = "ar"
FRAME_WAIT_S = 0.05
"""Longest wait for the frame of a pose that came before it."""


def bgr_image(frame: Frame) -> np.ndarray:
    """The frame's pixels as a contiguous ``(H, W, 3)`` BGR uint8 array."""
    image = image_of(frame)
    if image.ndim == 2:
        return cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
    return np.ascontiguousarray(image)


def overlay_message(svc: Service, pose: HeadPose, image: np.ndarray, jpeg: int) -> Overlay:
    """The overlay of ``image`` (H, W, 3) for the frame of ``pose``."""
    header = svc.header_for(pose)
    if jpeg <= 0:
        return Overlay.from_array(header, image)
    ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, jpeg])
    if not ok:
        raise ProtoError("overlay: JPEG encoding failed")
    return Overlay.from_jpeg(header, data.tobytes(), image.shape[1], image.shape[0])


class Drawn:
    """The latest frame drawn on, so that the poses of its other faces draw on it too."""

    def __init__(self) -> None:
        self.key: tuple[str, int] | None = None
        self.image: np.ndarray | None = None

    def base(self, pose: HeadPose, frame: Frame) -> np.ndarray:
        """What to draw ``pose`` on: the frame as drawn so far, or its pixels."""
        key = (pose.header.run_id, pose.header.frame_index)
        if key == self.key and self.image is not None:
            return self.image
        return bgr_image(frame)

    def keep(self, pose: HeadPose, image: np.ndarray) -> None:
        self.key, self.image = (pose.header.run_id, pose.header.frame_index), image


def draw(svc: Service, op: OverlayOperator, pose: HeadPose, frame: Frame, jpeg: int,
         drawn: Drawn | None = None) -> Overlay:
    """The overlay of ``frame`` at ``pose`` (over the frame's other faces in ``drawn``).

    Raises
    ------
    ProtoError, ValueError
        For a pose made for another image size, or a frame that does not decode.
    """
    image = bgr_image(frame) if drawn is None else drawn.base(pose, frame)
    if (pose.image_width, pose.image_height) != (image.shape[1], image.shape[0]):
        raise ProtoError(f"pose for a {pose.image_width} x {pose.image_height} image, "
                         f"frame is {image.shape[1]} x {image.shape[0]}")
    rendered = op(image, [pose_of(pose)])
    if drawn is not None:
        drawn.keep(pose, rendered)
    return overlay_message(svc, pose, rendered, jpeg)


def serve(svc: Service, op: OverlayOperator, opts: AROptions) -> None:
    """Render overlays until stopped."""
    frames = svc.frame_store()
    images = svc.share_images(opts.shm_overlays)
    unreliable = without_frame = 0
    drawn = Drawn()
    poses = svc.messages("pose", capacity=opts.capacity)
    svc.ready(f"renderer {op.ctx.info.get('GL_RENDERER', '?')}")
    for got in poses:
        pose = got.message
        assert isinstance(pose, HeadPose)
        frames.forget_before(pose.header.run_id, pose.header.frame_index)
        if not op.draws(pose_of(pose)):
            unreliable += 1
        # The frame and its pose come from different publishers: the pose may come first.
        elif (frame := frames.take(pose.header.run_id, pose.header.frame_index,
                                   FRAME_WAIT_S, keep=True)) is None:
            without_frame += 1  # its frame is gone: never received, or pushed out
            svc.stats.dropped += 1
        else:
            with svc.answering(f"pose {pose.header.frame_index}"):
                try:
                    svc.publish(draw(svc, op, pose, frame.message, opts.jpeg, drawn))
                except (ProtoError, ValueError) as exc:
                    svc.reject("pose", f"no overlay: {exc}")
        svc.set_state("running", f"{svc.stats.frames_out} overlays drawn; not drawn: "
                      f"{unreliable} unreliable poses, {without_frame} poses whose frame was "
                      f"gone, {svc.stats.dropped - without_frame} poses skipped while busy; "
                      f"{images.line()}")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: ``python -m services.ar.service``."""
    args = parse_service_args(NAME, "Draw 3D glasses on each frame at the estimated head pose.",
                              AROptions, argv)
    log = init_process(NAME, args.verbose)
    try:
        ctx = moderngl.create_standalone_context(backend=args.options.backend)
    except Exception as exc:  # moderngl raises plain Exception when no context can be made
        log.error("no OpenGL context (backend %s): %s", args.options.backend, exc)
        return 1
    op = OverlayOperator(args.options.overlay, ctx)
    try:
        with Service(NAME, args.bus) as svc:
            serve(svc, op, args.options)
    finally:
        op.close()
        ctx.release()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
