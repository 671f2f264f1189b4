"""The annotated video and the progress of ``aamtrack track`` and ``aamtrack export``: what
is checked before a run, and the loops that write it (the drawing is the library's,
:mod:`aamcore.annotate`)."""

from __future__ import annotations

import argparse
from collections import defaultdict
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any


def add_annotate(p: argparse.ArgumentParser, export: bool) -> None:
    p.add_argument("--annotate", type=Path, metavar="OUT.mp4",
                   help="write the video with the landmarks, head axes, glasses, face ids and "
                   "expressions drawn on every frame (.mp4 or .avi)"
                   + (" (with --video)" if export else ""))
    if export:
        p.add_argument("--video", type=Path, help="with --annotate: the video the run was "
                       "made from")


def annotate_problem(args: argparse.Namespace, export: bool) -> str:
    """Why ``--annotate`` (with ``--video`` for ``export``) cannot be done ("" when it can
    be tried)."""
    from aamcore.annotate import video_output_problem

    if export and (args.annotate is None) != (args.video is None):
        return "--annotate and --video go together: the video is what is drawn on"
    if args.annotate is None:
        return ""
    if problem := video_output_problem(args.annotate):
        return f"--annotate {problem}"
    return ""


def video_problem(video: Path) -> str:
    """Why ``video`` cannot be tracked ("" when it can): missing, a folder, not a video."""
    from services.source.capture import InputSpec, SourceError, VideoInput

    try:
        VideoInput(InputSpec(video=str(video))).close()
    except SourceError as exc:
        return str(exc).removeprefix("video file ")
    return ""


def shown(items: Iterable[Any], what: str, total: int, unit: str = "frame") -> Iterator[Any]:
    """``items`` with the count done of ``total``, the rate and the time left shown
    (:mod:`aamcore.progress`); the command says what it did at the end."""
    from aamcore.progress import progress

    return progress(items, what, total=total or None, unit=unit, summary=False)


def recording_video_problem(recording: Path, messages: list, video: Path, frames: int) -> str:
    """Why ``video`` is not the video of the run ``recording`` holds ("" when it may be)."""
    from aamcore.io.video import video_facts

    runs = {m.header.run_id for m in messages if m.KIND == "fit"}
    if len(runs) > 1:
        return f"{recording} holds {len(runs)} runs: an annotated video is made of one"
    eos = next((m for m in messages if m.KIND == "eos"), None)
    fitted = 1 + max((m.header.frame_index for m in messages if m.KIND == "fit"), default=-1)
    made_of = eos.total_frames if eos is not None else fitted
    if made_of != frames and (eos is not None or fitted > frames):
        return (f"{recording} is a run of {made_of} frames and {video} has {frames}: give "
                "--video the video the run was made from")
    pose = next((m for m in messages if m.KIND == "pose"), None)
    if pose is not None:
        size = video_facts(video)[2]
        if size != (pose.image_width, pose.image_height):
            return (f"{recording} is a run of {pose.image_width}x{pose.image_height} frames and "
                    f"{video} is {size[0]}x{size[1]}: give --video the video the run was made "
                    "from")
    return ""


def export_annotated(messages: list, results: list, video: Path, out: Path, frames: int
                     ) -> tuple[int, str]:
    """Write ``video`` with a recording's ``results`` drawn on it to ``out``; the frames
    written and why the glasses are not drawn ("" when they are)."""
    import cv2

    from aamcore.annotate import AnnotatedVideo
    from aamcore.io.video import video_facts

    by_frame: dict[int, list] = defaultdict(list)
    for result in results:
        by_frame[result.frame_index].append(result)
    pose = next((m for m in messages if m.KIND == "pose"), None)
    K = None if pose is None else pose.intrinsics
    capture = cv2.VideoCapture(str(video))
    annotated = AnnotatedVideo(out, video_facts(video)[1])
    try:
        for index in shown(range(frames), f"annotating {video.name}", frames):
            ok, frame = capture.read()
            if not ok:
                break
            annotated.put(frame, by_frame.get(index, []), K)
    finally:
        capture.release()
        written = annotated.close()
    return written, annotated.glasses_problem
