"""The frame source: reads a video input and publishes its frames, then end of stream.

``aamtrack service source --video FILE [--pace realtime|fast] [--loop N] [--jpeg Q]``

Frames go out raw (``(H, W, 3)`` BGR; Zenoh moves them through shared memory
between processes of one host) or JPEG-encoded with ``--jpeg``. Pacing is the
file's frame rate, or ``fast``: as fast as the fitter answers, with at most
``--window`` frames in flight (:class:`~services.source.pacing.CreditWindow`).
At the end the source publishes ``EndOfStream`` with the number of frames it
published and why it stopped, and exits: 0 at the end of the input or on a
stop, 1 when the input failed.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import cv2
import numpy as np

from proto import EndOfStream, Frame
from services.bus.runtime import BusOptions, Service, init_process, service_parser
from services.source.capture import InputSpec, SourceError, VideoInput
from services.source.pacing import PACES, CreditWindow, RealTimePacer

NAME = "source"
EOS_LINGER = 0.3
"""Seconds to keep the session open after end of stream so that it is delivered."""


def build_parser() -> argparse.ArgumentParser:
    parser = service_parser(NAME, "Publish the frames of a video file, camera or stream URL.")
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--video", help="video file")
    where.add_argument("--camera", type=int, help="camera index (OpenCV)")
    where.add_argument("--url", help="stream URL (rtsp://, http://, ...)")
    parser.add_argument("--pace", choices=PACES, default="realtime",
                        help="realtime: the file's frame rate; fast: as fast as fits come back")
    parser.add_argument("--loop", type=int, default=1, metavar="N",
                        help="play a file N times (0: until stopped); default 1")
    parser.add_argument("--jpeg", type=int, default=0, metavar="QUALITY",
                        help="publish JPEG frames of this quality (1-100) instead of raw")
    parser.add_argument("--window", type=int, default=2,
                        help="fast pacing: frames published ahead of the last fit (default 2)")
    parser.add_argument("--answer-timeout", type=float, default=1.0,
                        help="fast pacing: seconds to wait for a fit before going on")
    parser.add_argument("--max-frames", type=int, default=0, help="stop after N frames")
    parser.add_argument("--wait-for", default="", metavar="SERVICES",
                        help="comma-separated services to wait for before the first frame")
    parser.add_argument("--wait-timeout", type=float, default=60.0,
                        help="seconds to wait for --wait-for services (then go on)")
    return parser


def input_spec(args: argparse.Namespace) -> InputSpec:
    """The input named by ``--video``, ``--camera`` or ``--url``."""
    return InputSpec(video=args.video, camera=args.camera, url=args.url)


def make_frame(
    svc: Service, index: int, image: np.ndarray, captured_ns: int, jpeg_quality: int
) -> Frame:
    """A raw or JPEG ``Frame`` message of ``image`` (H, W, 3) uint8."""
    header = svc.header(index, captured_ns)
    if jpeg_quality <= 0:
        return Frame.from_array(header, image)
    ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, jpeg_quality])
    if not ok:
        raise SourceError(f"JPEG encoding of frame {index} failed")
    height, width = image.shape[:2]
    return Frame.from_jpeg(header, data.tobytes(), width, height)


def frame_problem(image: np.ndarray, size: tuple[int, int]) -> str:
    """Why a captured frame cannot be published on a stream of ``size`` (W, H), or ``""``."""
    if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
        return f"frame of type {image.dtype} and shape {image.shape}, not (H, W, 3) uint8"
    if (image.shape[1], image.shape[0]) != size:
        return (f"frame of {image.shape[1]} x {image.shape[0]} on a stream of "
                f"{size[0]} x {size[1]}")
    return ""


def make_gate(svc: Service, args: argparse.Namespace, fps: float) -> Callable[[int], bool]:
    """The wait before frame ``k``: real-time pacing or the fit credit window."""
    if args.pace == "realtime" and args.video is not None:
        return RealTimePacer(fps, svc.wait).wait
    if args.pace == "realtime":
        return lambda k: not svc.stopping  # a camera or stream sets its own pace
    window = CreditWindow(args.window, args.answer_timeout)

    def on_fit(sample: object) -> None:
        msg = svc.decode(sample.payload.to_bytes(), "fit", source="fit")  # type: ignore[attr-defined]
        if msg is not None:
            window.answer(msg.header.frame_index)

    svc.subscribe(svc.key("fit"), on_fit)
    svc.stop_hooks.append(window.stop)
    return window.wait


def publish_frames(svc: Service, video: VideoInput, args: argparse.Namespace) -> tuple[int, str]:
    """Publish every frame of ``video``; return ``(frames published, reason it ended)``."""
    gate = make_gate(svc, args, video.fps)
    size = (video.width, video.height)
    count = 0
    for image in video.frames():
        if svc.stopping:
            return count, "stopped"
        problem = frame_problem(image, size)
        if problem:
            svc.reject("capture", problem)
            continue
        if not gate(count):
            return count, "stopped"
        started = time.perf_counter()
        svc.publish(make_frame(svc, count, image, time.time_ns(), args.jpeg))
        svc.stats.count_in()
        svc.stats.last_frame = count
        svc.stats.latency.add(1000 * (time.perf_counter() - started))
        count += 1
        if args.max_frames and count >= args.max_frames:
            break
    return count, "stopped" if svc.stopping else "end_of_file"


def publish_eos(svc: Service, count: int, reason: str) -> None:
    """Publish ``EndOfStream`` and give it time to leave."""
    svc.publish(EndOfStream(svc.header(max(count - 1, 0)), total_frames=count, reason=reason),
                count=False)
    svc.log.info("end of stream: %d frames, %s", count, reason)
    time.sleep(EOS_LINGER)


def run(args: argparse.Namespace) -> int:
    """Run the source with parsed arguments; the exit code."""
    log = init_process(NAME, args.verbose)
    if not 0 <= args.jpeg <= 100:
        log.error("--jpeg quality must be 0 (raw) to 100, got %d", args.jpeg)
        return 2
    spec = input_spec(args)
    with Service(NAME, BusOptions.from_args(args)) as svc:
        try:
            video = VideoInput(spec, args.loop)
        except SourceError as exc:
            log.error("%s", exc)
            svc.set_state("failed", str(exc))
            publish_eos(svc, 0, f"error: {exc}")
            return 1
        with video:
            svc.ready(f"{spec.describe()}: {video.width} x {video.height} at {video.fps:g} fps")
            waiting = [s for s in args.wait_for.split(",") if s]
            missing = svc.wait_for_alive(waiting, args.wait_timeout) if waiting else []
            if missing:
                log.warning("going on without %s (not alive after %g s)", missing,
                            args.wait_timeout)
            try:
                count, reason = publish_frames(svc, video, args)
            except SourceError as exc:
                log.error("%s", exc)
                svc.set_state("failed", str(exc))
                publish_eos(svc, svc.stats.frames_out, f"error: {exc}")
                return 1
        svc.set_state("stopping", reason)
        publish_eos(svc, count, reason)
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point: ``python -m services.source.service --video FILE``."""
    return run(build_parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
