"""``aamtrack export`` and ``aamtrack track``: per-frame results for other tools.

- ``aamtrack export RUN.rec --csv OUT.csv`` (or ``--jsonl OUT.jsonl``): one
  row per frame of a recording made with ``aamtrack run --record``;
  ``--rrd OUT.rrd`` replays it into a Rerun recording to view.
- ``aamtrack track VIDEO --csv OUT.csv``: the same rows straight from a
  video through the Python API (:class:`aamcore.tracker.FaceTracker`), no bus,
  with the default profile's expressions (``--no-expression``: none) and every option of
  the tracker's configuration (:mod:`services.cli.track_options`); with
  ``--max-faces N``, one row per face per frame.

Rows are written as they come: whatever was exported before a damaged record
or a video that ends mid-frame is kept, and the command says what happened.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``export`` and ``track``."""
    p = subparsers.add_parser("export", help="a recording's per-frame results as CSV, JSON "
                              "Lines or a Rerun recording",
                              description="Write one row per frame of RECORDING.")
    p.add_argument("recording", type=Path, help="a .rec file of aamtrack run --record")
    _outputs(p)
    p.add_argument("--rrd", type=Path, help="replay it into this Rerun recording")
    p.set_defaults(func=cmd_export)
    p = subparsers.add_parser("track", help="track a video without the bus and write its "
                              "per-frame results", description="Run the Python API's "
                              "FaceTracker on VIDEO.")
    p.add_argument("video", type=Path)
    _outputs(p)
    from services.cli.track_options import add_track_options

    add_track_options(p)
    p.set_defaults(func=cmd_track)


def _outputs(p: argparse.ArgumentParser) -> None:
    p.add_argument("--csv", type=Path, help="write CSV rows here")
    p.add_argument("--jsonl", type=Path, help="write JSON Lines here")


def _writers(args: argparse.Namespace, n_points: int, class_names: tuple[str, ...]) -> list:
    from aamcore.results import ResultWriter

    return [ResultWriter(path, kind, n_points, class_names)
            for kind, path in (("csv", args.csv), ("jsonl", args.jsonl)) if path is not None]


def _check_outputs(args: argparse.Namespace) -> str:
    """The first problem with an output file asked for ("" when there is none)."""
    from services.stack.preflight import PreflightError, check_output

    for option in ("csv", "jsonl", "rrd"):
        path = getattr(args, option, None)
        if path is not None:
            try:
                check_output(f"--{option}", path)
            except PreflightError as exc:
                return str(exc)
    return ""


def _fail(command: str, message: str, code: int) -> int:
    print(f"aamtrack {command}: error: {message}", file=sys.stderr)
    return code


def cmd_export(args: argparse.Namespace) -> int:
    """``aamtrack export RUN.rec``."""
    from services.stack.export import results_of
    from services.stack.recorder import RecordingError, read_recording

    if args.csv is None and args.jsonl is None and args.rrd is None:
        return _fail("export", "give --csv, --jsonl and/or --rrd", 2)
    if problem := _check_outputs(args):
        return _fail("export", problem, 2)
    try:
        recording = read_recording(args.recording)
    except (RecordingError, OSError) as exc:
        return _fail("export", str(exc), 2)
    exported = results_of(recording.messages)
    writers = _writers(args, exported.n_points, exported.class_names)
    for writer in writers:
        with writer:
            for result in exported.results:
                writer.write(result)
    if args.rrd is not None:
        replay(recording.messages, args.rrd)
    print(f"exported {len(exported.results)} frames of {args.recording}", file=sys.stderr)
    if recording.stopped:
        return _fail("export", f"the recording is damaged; exported what came before: "
                     f"{recording.stopped}", 1)
    return 0


def replay(messages: list, rrd: Path) -> None:
    """Log recorded messages into a new ``.rrd`` file."""
    from services.rerun_logger.blueprint import build_blueprint
    from services.rerun_logger.dispatch import StreamLogger
    from services.rerun_logger.recording import open_recording
    from services.rerun_logger.service import load_head_model

    recording = open_recording(rrd, None, build_blueprint())
    try:
        logger = StreamLogger(recording.stream, load_head_model())
        for msg in messages:
            logger.log(msg)
    finally:
        recording.close()


def cmd_track(args: argparse.Namespace) -> int:
    """``aamtrack track VIDEO``."""
    if args.csv is None and args.jsonl is None:
        return _fail("track", "give --csv and/or --jsonl", 2)
    if not args.video.is_file():
        return _fail("track", f"{args.video}: no such file", 2)
    if problem := _check_outputs(args):
        return _fail("track", problem, 2)
    from services.bus.options import OptionError
    from services.cli.track_options import track_options

    try:
        opts = track_options(args)
    except OptionError as exc:
        return _fail("track", str(exc), 2)
    from aamcore.model.file import ModelFileError
    from aamcore.tracker import FaceTracker

    try:
        tracker = FaceTracker(opts.tracking, model=opts.model, profile=opts.profile,
                              classifier=opts.classifier if opts.expression else False,
                              camera=opts.calibration or opts.fov)
    except (ModelFileError, OSError, ValueError) as exc:
        return _fail("track", str(exc), 2)
    names = tracker.class_names
    writers = _writers(args, tracker.model.aam.scheme.n_points, names)
    try:
        for faces in tracker.process_video_faces(args.video):
            for writer in writers:
                for result in faces:
                    writer.write(result)
    except OSError as exc:
        return _fail("track", str(exc), 2)
    finally:
        for writer in writers:
            writer.close()
    print(f"tracked {tracker.frames} frames of {args.video}", file=sys.stderr)
    expected = frame_count(args.video)
    if tracker.frames == 0 or tracker.frames < expected:
        return _fail("track", f"{args.video}: the video ended after {tracker.frames} of its "
                     f"{expected} frames (cut short?); the rows of those frames are written", 1)
    return 0


def frame_count(video: Path) -> int:
    """The number of frames a video's container announces (0 when it does not say)."""
    import cv2

    capture = cv2.VideoCapture(str(video))
    try:
        return max(int(capture.get(cv2.CAP_PROP_FRAME_COUNT) or 0), 0)
    finally:
        capture.release()
