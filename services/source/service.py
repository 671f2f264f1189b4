"""The frame source: reads a video input and publishes its frames, then end of stream.

``aamtrack service source --video FILE [--pace realtime|fast] [--loop N] [--jpeg Q]``

Frames go out raw (``(H, W, 3)`` BGR; Zenoh moves them through shared memory
between processes of one host) or JPEG-encoded with ``--jpeg``, numbered from
0 within the source's run (its run id: ``--run-id`` or a new one at each
start). Pacing is the file's frame rate, or ``fast``: as fast as the slowest stage
answers, with at most ``--window`` frames in flight
(:class:`~services.source.pacing.CreditWindow`, :mod:`services.source.answers`). At the
end the source publishes ``EndOfStream`` (sent so that it must arrive) with the number of
frames it published and why it stopped, and exits: 0 at the end of the input
or on a stop, 1 when the input failed. A file that ends before the frames its
container states (cut short or damaged) ends like any other, every frame read
published, with an end of stream whose reason is an error naming the file and
its last frame.
"""

from __future__ import annotations

import sys
import time
import uuid
from collections.abc import Callable, Sequence
from typing import Any

import cv2
import numpy as np

from proto import EndOfStream, Frame
from services.bus.args import parse_service_args
from services.bus.process import init_process
from services.bus.session import Service
from services.source.answers import Answers
from services.source.capture import InputSpec, SourceError, VideoInput
from services.source.options import SourceOptions
from services.source.pacing import CreditWindow, RealTimePacer

NAME = "source"


def new_run_id() -> str:
    """A fresh run id: ``run-`` and 12 hex digits."""
    return f"run-{uuid.uuid4().hex[:12]}"


def make_frame(
    svc: Service, index: int, image: np.ndarray, captured_ns: int, jpeg_quality: int,
    media_ns: int = 0,
) -> Frame:
    """A raw or JPEG ``Frame`` message of ``image`` (H, W, 3) uint8."""
    header = svc.header(index, captured_ns, media_time_ns=media_ns)
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


def make_gate(svc: Service, opts: SourceOptions, fps: float) -> Callable[[int], bool]:
    """The wait before frame ``k``: real-time pacing, or the credit window over the answers
    of every stage of the run (:mod:`services.source.answers`)."""
    if opts.pace == "realtime" and opts.video is not None:
        return RealTimePacer(fps, svc.wait).wait
    if opts.pace == "realtime":
        return lambda k: not svc.stopping  # a camera or stream sets its own pace
    window = CreditWindow(opts.window, opts.answer_timeout)
    answers = Answers(opts.wait_for)

    def on_answer(sample: Any) -> None:
        key = str(sample.key_expr)
        msg = svc.screen.check(sample.payload.to_bytes(), key, key.rsplit("/", 1)[-1])
        if msg is not None:
            window.answer(answers.saw(msg))

    for kind in answers.listens_to:
        svc.subscribe(svc.key(kind), on_answer)
    svc.stop_hooks.append(window.stop)

    def gate(k: int) -> bool:
        going_on = window.wait(k)
        answers.skip_to(window.answered)  # what the window gave up on after its timeout
        return going_on

    return gate


class MediaClock:
    """A frame's media time (``Header.media_time_ns``): a file's frame position on its frame
    rate, the same run fast or in real time; a live input's time since its first frame."""

    def __init__(self, video: VideoInput) -> None:
        self.fps = video.fps if video.spec.is_file else None
        self.first_ns: int | None = None

    def __call__(self, index: int, captured_ns: int) -> int:
        if self.fps is not None:
            return round(index * 1e9 / self.fps)
        if self.first_ns is None:
            self.first_ns = captured_ns
        return captured_ns - self.first_ns


def publish_frames(svc: Service, video: VideoInput, opts: SourceOptions) -> tuple[int, str]:
    """Publish every frame of ``video``; return ``(frames published, reason it ended)``."""
    gate = make_gate(svc, opts, video.fps)
    clock = MediaClock(video)
    size = (video.width, video.height)
    count = 0
    images = svc.share_images(opts.shm_frames)
    for image in video.frames(in_place=True):
        if svc.stopping:
            return count, "stopped"
        problem = frame_problem(image, size)
        if problem:
            svc.reject("capture", problem)
            continue
        if not gate(count):
            return count, "stopped"
        started = time.perf_counter()
        captured = time.time_ns()
        svc.publish(make_frame(svc, count, image, captured, opts.jpeg, clock(count, captured)))
        svc.stats.count_in()
        svc.stats.last_frame = count
        svc.stats.latency.add(1000 * (time.perf_counter() - started))
        svc.set_state("running", f"{video.spec.describe()}: {images.line()}")
        count += 1
        if opts.max_frames and count >= opts.max_frames:
            break
    if svc.stopping:
        return count, "stopped"
    return count, f"error: {video.damaged}" if video.damaged else "end_of_file"


def publish_eos(svc: Service, count: int, reason: str) -> None:
    """Publish ``EndOfStream``; it goes out with blocking congestion control, so it arrives."""
    svc.publish(EndOfStream(svc.header(max(count - 1, 0)), total_frames=count, reason=reason),
                count=False)
    svc.log.info("end of stream: %d frames, %s", count, reason)


def serve(svc: Service, opts: SourceOptions) -> int:
    """Open the input and publish it; the exit code."""
    spec = InputSpec.of(opts)
    try:
        video = VideoInput(spec, opts.loop)
    except SourceError as exc:
        svc.log.error("%s", exc)
        svc.set_state("failed", str(exc))
        publish_eos(svc, 0, f"error: {exc}")
        return 1
    with video:
        svc.ready(f"{spec.describe()}: {video.width} x {video.height} at {video.fps:g} fps")
        missing = svc.wait_for_alive(opts.wait_for, opts.wait_timeout) if opts.wait_for else []
        if missing and not svc.stopping:
            svc.log.warning("going on without %s (not alive after %g s)", missing,
                            opts.wait_timeout)
        try:
            count, reason = publish_frames(svc, video, opts)
        except SourceError as exc:
            svc.log.error("%s", exc)
            svc.set_state("failed", str(exc))
            publish_eos(svc, svc.stats.frames_out, f"error: {exc}")
            return 1
    svc.set_state("stopping", f"{reason}; {svc.images.line()}" if svc.images else reason)
    publish_eos(svc, count, reason)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: ``python -m services.source.service --video FILE``."""
    args = parse_service_args(NAME, "Publish the frames of a video file, camera or stream URL.",
                              SourceOptions, argv)
    if not args.options.has_input:
        print("aamtrack service source: error: give --video, --camera or --url", file=sys.stderr)
        return 2
    init_process(NAME, args.verbose)
    bus = args.bus if args.bus.run_id else args.bus.replace(run_id=new_run_id())
    with Service(NAME, bus) as svc:
        return serve(svc, args.options)


if __name__ == "__main__":
    raise SystemExit(main())
