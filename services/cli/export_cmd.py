"""``aamtrack export`` and ``aamtrack track``: per-frame results for other tools.

- ``aamtrack export RUN.rec --csv OUT.csv`` (or ``--jsonl OUT.jsonl``): one
  row per frame of a recording made with ``aamtrack run --record`` or ``aamtrack
  record``; ``--rrd OUT.rrd`` replays it into a Rerun recording to view. Only the
  messages signed by the run's services are exported, checked with the run's public keys
  the recording holds (``--trust FP``: the launcher key they must come from); the
  columns ``run_id`` and ``verified`` say what each row was checked against, and the
  command says how many messages were left out.
- ``aamtrack track VIDEO --csv OUT.csv``: the same rows straight from a
  video through the Python API (:class:`aamcore.tracker.FaceTracker`), no bus,
  with the default profile's expressions (``--no-expression``: none) and every option of
  the options tree (:mod:`services.cli.track_options`); with
  ``--max-faces N``, one row per face per frame.

Rows are written as they come: whatever was exported before a damaged record
or a video that ends mid-frame is kept, and the command says what happened.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

from services.cli.annotated import (
    add_annotate,
    annotate_problem,
    shown,
    video_problem,
)
from services.cli.commands import add_command


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``export`` and ``track``."""
    from aamcore.results import columns_notes

    p = add_command(subparsers, "export",
                    description="Write one row per frame of RECORDING.", epilog=columns_notes())
    p.add_argument("recording", type=Path, help="a .rec file of aamtrack run --record")
    _outputs(p)
    p.add_argument("--rrd", type=Path, help="replay it into this Rerun recording")
    p.add_argument("--trust", default="", metavar="FP",
                   help="the fingerprint of the run's launcher key (aamtrack run printed it): "
                   "refuse a recording of any other run")
    add_annotate(p, export=True)
    p.set_defaults(func=cmd_export)
    p = add_command(subparsers, "track", description="Run the Python API's "
                    "FaceTracker on VIDEO.", epilog=columns_notes())
    p.add_argument("video", type=Path, help="the video file to track")
    _outputs(p)
    add_annotate(p, export=False)
    from services.cli.track_options import add_track_options

    add_track_options(p)
    p.set_defaults(func=cmd_track)


def _outputs(p: argparse.ArgumentParser) -> None:
    p.add_argument("--csv", type=Path, help="write CSV rows here")
    p.add_argument("--jsonl", type=Path, help="write JSON Lines here")


def _writers(args: argparse.Namespace, n_points: int, class_names: tuple[str, ...],
             extra: dict[str, str] | None = None) -> list:
    from aamcore.results import ResultWriter

    return [ResultWriter(path, kind, n_points, class_names, extra)
            for kind, path in (("csv", args.csv), ("jsonl", args.jsonl)) if path is not None]


def _check_outputs(args: argparse.Namespace) -> str:
    """The first problem with an output file asked for ("" when there is none)."""
    from services.stack.preflight import PreflightError, check_output

    for option in ("csv", "jsonl", "rrd", "annotate"):
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
    from aamcore.io.video import video_facts
    from services.cli.annotated import export_annotated, recording_video_problem
    from services.stack.export import results_of
    from services.stack.recorder import RecordingError, read_recording

    if not any((args.csv, args.jsonl, args.rrd, args.annotate)):
        return _fail("export", "give --csv, --jsonl, --rrd and/or --annotate with --video", 2)
    if problem := annotate_problem(args, export=True) or _check_outputs(args):
        return _fail("export", problem, 2)
    if args.video is not None and (problem := video_problem(args.video)):
        return _fail("export", f"--video {problem}", 2)
    try:
        recording = read_recording(args.recording, trust=args.trust)
    except (RecordingError, OSError) as exc:
        return _fail("export", str(exc), 2)
    exported = results_of(recording.messages)
    frames = len({(r.frame_index) for r in exported.results})
    if args.video is not None:
        total = video_facts(args.video)[0]
        if problem := recording_video_problem(args.recording, recording.messages, args.video,
                                              total):
            return _fail("export", problem, 2)
    keys = recording.run_keys
    writers = _writers(args, exported.n_points, exported.class_names, {
        "run_id": keys.run_id if keys is not None else "",
        "verified": f"launcher key {keys.fingerprint}" if keys is not None else "no"})
    try:
        if writers:
            for result in shown(exported.results, "writing rows", len(exported.results), "row"):
                for writer in writers:
                    writer.write(result)
    finally:
        for writer in writers:
            writer.close()
    if args.rrd is not None and (problem := replay(recording.messages, args.rrd)):
        return _fail("export", f"--rrd {problem}", 1)
    said = (f"exported {len(exported.results)} rows ({frames} frames) of {args.recording}, "
            f"{recording.verified}")
    if recording.ignored:
        said += ("; left out (not the run's): "
                 + ", ".join(f"{n} {why}" for why, n in sorted(recording.ignored.items())))
    if args.annotate is not None:
        written, glasses = export_annotated(recording.messages, exported.results, args.video,
                                            args.annotate, total)
        said += f"; annotated video {args.annotate} ({written} frames)"
        if glasses:
            said += f"; {glasses}"
    print(said, file=sys.stderr)
    if recording.stopped:
        return _fail("export", f"the recording is damaged; exported what came before: "
                     f"{recording.stopped}", 1)
    return 0


def replay(messages: list, rrd: Path) -> str:
    """Log recorded messages into a new ``.rrd`` file; ``""``, or why it could not be
    written whole (a full disk)."""
    from services.rerun_logger.blueprint import build_blueprint
    from services.rerun_logger.dispatch import StreamLogger
    from services.rerun_logger.recording import open_recording
    from services.rerun_logger.service import load_head_model

    recording = open_recording(rrd, None, build_blueprint())
    try:
        logger = StreamLogger(recording.stream, load_head_model())
        for msg in shown(messages, f"replaying into {rrd.name}", len(messages), "message"):
            logger.log(msg)
    finally:
        problem = recording.file_problem(recording.close())
    return problem


def cmd_track(args: argparse.Namespace) -> int:
    """``aamtrack track VIDEO``."""
    if args.csv is None and args.jsonl is None and args.annotate is None:
        return _fail("track", "give --csv, --jsonl and/or --annotate", 2)
    if problem := annotate_problem(args, export=False) or _check_outputs(args):
        return _fail("track", problem, 2)
    from services.bus.options import OptionError
    from services.cli.track_options import track_options

    try:
        _, options = track_options(args)
    except OptionError as exc:
        return _fail("track", str(exc), 2)
    if problem := video_problem(args.video):
        return _fail("track", problem, 2)
    from aamcore.io.video import ended_early, ended_early_problem, video_facts
    from aamcore.model.file import ModelFileError
    from aamcore.tracker import FaceTracker

    try:
        tracker = FaceTracker(options)
    except (ModelFileError, OSError, ValueError) as exc:
        return _fail("track", str(exc), 2)
    expected = video_facts(args.video)[0]
    try:
        said, glasses = track_video(tracker, args, expected)
    except OSError as exc:
        return _fail("track", str(exc), 2)
    print(said, file=sys.stderr)
    if glasses:
        print(f"aamtrack track: {glasses}", file=sys.stderr)
    if tracker.frames == 0 or ended_early(tracker.frames, expected):
        return _fail("track", f"{ended_early_problem(args.video, tracker.frames, expected)}; "
                     "the rows of the frames before are written", 1)
    return 0


def track_video(tracker: Any, args: argparse.Namespace, expected: int) -> tuple[str, str]:
    """Track ``args.video``, writing the rows and the annotated video asked for; what was
    done (one line) and why the glasses are not drawn ("" when they are)."""
    from aamcore.annotate import AnnotatedVideo
    from aamcore.io.video import video_facts

    writers = _writers(args, tracker.model.aam.scheme.n_points, tracker.class_names)
    video = AnnotatedVideo(args.annotate, video_facts(args.video)[1]) if args.annotate else None
    started, rows, K = time.perf_counter(), 0, None
    try:
        for frame, faces in shown(tracker.process_video_frames(args.video),
                                  f"tracking {args.video.name}", expected):
            for writer in writers:
                for result in faces:
                    writer.write(result)
            rows += len(faces)
            if video is not None:
                if K is None:
                    K = tracker.camera_matrix(frame.shape[1], frame.shape[0])
                video.put(frame, faces, K)
    finally:
        for writer in writers:
            writer.close()
        if video is not None:
            video.close()
    spent = time.perf_counter() - started
    said = (f"tracked {tracker.frames} frames of {args.video} in {spent:.1f} s "
            f"({tracker.frames / max(spent, 1e-9):.1f} frames/s): {rows} rows"
            + (f", annotated video {args.annotate}" if video is not None else ""))
    return said, video.glasses_problem if video is not None else ""
