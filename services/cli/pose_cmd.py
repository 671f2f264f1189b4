"""``aamtrack synth`` and ``aamtrack eval pose``: ground-truth head pose sequences.

``synth`` renders the textured head under known poses to a video with
per-frame JSON. ``eval pose`` measures POSIT against OpenCV's SQPNP on exact
landmarks with 0-3 px noise, and the pose error over a sequence with the
generic head model, with a plot like the thesis's figure 14.4.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

from services.cli.commands import add_command
from services.cli.groups import eval_group

if TYPE_CHECKING:
    import numpy as np

    from aamcore.pose.head_model import HeadModel
    from aamcore.pose.intrinsics import CameraIntrinsics

SWEEP_CHOICES = ("yaw", "pitch", "roll", "distance", "all")


def register(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "synth")
    p.add_argument("--out", type=Path, required=True, help="output folder")
    p.add_argument("--frames", type=int, default=120, help="number of frames (default 120)")
    p.add_argument(
        "--sweep",
        choices=SWEEP_CHOICES,
        default="all",
        help="which pose parameter to sweep (default all, one after the other)",
    )
    _camera_options(p)
    p.add_argument("--photo", type=Path, help="texture photo (default: a frontal LFPW face)")
    p.add_argument("--landmarks", type=Path, help="the photo's 68-point .pts file")
    p.add_argument("--fps", type=float, default=30.0, help="frame rate of the video (default 30)")
    p.add_argument("--max-angle", type=float, default=40.0,
                   help="largest roll/pitch/yaw of the angle sweeps, degrees, below 90 "
                        "(default 40)")
    p.set_defaults(func=run_synth)

    e = eval_group(sub).add_parser(
        "pose", help="POSIT vs SQPNP on synthesized landmarks, and pose error over a sequence"
    )
    e.add_argument("--json", action="store_true", help="print the results as JSON")
    e.add_argument(
        "--sequence",
        type=Path,
        help="a folder written by 'aamtrack synth' "
        "(default: the poses are generated, nothing is rendered)",
    )
    e.add_argument("--frames", type=int, default=140, help="frames when generating (default 140)")
    e.add_argument("--sweep", choices=SWEEP_CHOICES, default="all",
                   help="which pose parameter to sweep when generating (default all)")
    _camera_options(e)
    e.add_argument("--noise", default="0,1,2,3", help="pixel noise levels (default 0,1,2,3)")
    e.add_argument(
        "--model",
        default="openface68",
        help="3D model for the sequence: openface68 (default), openface68-rigid, "
        "exact (the synthetic head's own points) or a CSV file (iBUG-68)",
    )
    e.add_argument(
        "--sequence-noise",
        type=float,
        default=1.0,
        help="pixel noise on the sequence's landmarks (default 1)",
    )
    e.add_argument("--plot", type=Path, help="PNG of estimate against truth per frame")
    e.add_argument("--seed", type=int, default=0, help="seed of the pixel noise (default 0)")
    e.add_argument(
        "--fits",
        action="store_true",
        help="also estimate the pose from AAM fits of the rendered frames (end to end)",
    )
    e.add_argument(
        "--fit-model",
        type=Path,
        help="68-point model for --fits (default: the stack's LFPW model, trained on first use)",
    )
    e.set_defaults(func=run_eval_pose)


def _camera_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--width", type=int, default=640, help="image width, pixels (default 640)")
    p.add_argument("--height", type=int, default=480, help="image height, pixels (default 480)")
    p.add_argument("--fov", type=float, default=60.0, help="horizontal field of view, degrees")
    p.add_argument(
        "--intrinsics",
        type=Path,
        help="calibration file (YAML, XML or JSON) instead of --width/--height/--fov",
    )


def _camera(args: argparse.Namespace) -> CameraIntrinsics:
    from aamcore.pose.intrinsics import CameraIntrinsics

    if args.intrinsics is not None:
        return CameraIntrinsics.from_file(args.intrinsics)
    return CameraIntrinsics.from_fov(args.width, args.height, args.fov)


def run_synth(args: argparse.Namespace) -> int:
    from aamcore.synth.head import synth_head
    from aamcore.synth.sequence import synthesize
    from aamcore.synth.texture import face_texture

    texture = None
    if args.photo is not None:
        from aamcore.io import read_image, read_pts

        if args.landmarks is None:
            raise ValueError("--photo needs --landmarks (its 68-point .pts file)")
        texture = face_texture(
            synth_head(), read_image(args.photo), read_pts(args.landmarks), str(args.photo)
        )
    path = synthesize(args.out, args.frames, args.sweep, _camera(args), texture, args.fps,
                      args.max_angle)
    print(f"wrote {args.frames} frames to {args.out} ({path.name}, video.mp4, frames/)")
    return 0


def _load_inputs(
    args: argparse.Namespace,
) -> tuple[list[np.ndarray], list[Any], CameraIntrinsics, HeadModel, str]:
    from aamcore.evaluation.pose import sequence_inputs
    from aamcore.synth.head import synth_head
    from aamcore.synth.sequence import exact_landmarks, sweep_poses

    if args.sequence is not None:
        landmarks, truths, camera, exact = sequence_inputs(args.sequence)
        return landmarks, truths, camera, exact, f"sequence {args.sequence}"
    camera = _camera(args)
    head = synth_head()
    poses = sweep_poses(args.sweep, args.frames)
    return (
        exact_landmarks(head, poses, camera),
        poses,
        camera,
        head.head_model(),
        f"{args.frames} generated poses, sweep {args.sweep}",
    )


def run_eval_pose(args: argparse.Namespace) -> int:
    import numpy as np

    from aamcore.evaluation.pose import evaluate_pose_sequence, plot_pose_sequence, posit_vs_sqpnp
    from aamcore.pose.head_model import head_model_named

    try:
        noise = [float(x) for x in args.noise.split(",") if x.strip()]
    except ValueError as exc:
        raise ValueError(f"--noise must be comma-separated numbers, got {args.noise!r}") from exc
    landmarks, truths, camera, exact, what = _load_inputs(args)
    comparison = posit_vs_sqpnp(landmarks, truths, camera, exact, noise, args.seed)
    model = head_model_named(args.model, exact)
    rng = np.random.default_rng(args.seed)
    noisy = [lm + rng.normal(0.0, args.sequence_noise, np.shape(lm)) for lm in landmarks]
    sequence = evaluate_pose_sequence(noisy, truths, camera, model)
    if args.plot is not None:
        plot_pose_sequence(
            sequence, args.plot, f"{model.name}, {what}, {args.sequence_noise:g} px noise"
        )
    fitted = _fitted_sequence(args, truths, camera, model) if args.fits else None
    report = {
        "aam_fits": fitted,
        "input": what,
        "camera": camera.to_json(),
        "posit_vs_sqpnp": comparison,
        "sequence": {k: v for k, v in sequence.items() if k != "per_frame"}
        | {"noise_px": args.sequence_noise},
        "plot": str(args.plot) if args.plot else None,
    }
    if args.json:
        print(json.dumps(report, indent=1))
    else:
        _print_report(report)
    return 0


def _fitted_sequence(
    args: argparse.Namespace, truths: list[Any], camera: CameraIntrinsics, model: HeadModel
) -> dict[str, Any]:
    """Pose errors of the estimator on the tracker's landmarks of the sequence's frames."""
    from aamcore.evaluation.pose import tracked_sequence_errors
    from aamcore.fitting.fitter import Fitter
    from aamcore.fitting.model import FittingModel
    from aamcore.fitting.tracker import Tracker
    from aamcore.fitting.training.prepare import default_model_path
    from aamcore.io.video import video_frames
    from aamcore.synth.sequence import render_sequence

    if args.sequence is not None:
        frames = video_frames(args.sequence / "video.mp4")
    else:
        frames = (image for image, _, _ in render_sequence(truths, camera))
    tracker = Tracker(Fitter(FittingModel.load(args.fit_model or default_model_path())))
    return tracked_sequence_errors(frames, truths, camera, model, tracker)


def _print_report(report: dict[str, Any]) -> None:
    cmp_ = report["posit_vs_sqpnp"]
    print(f"{report['input']}; exact model {cmp_['model']}; mean absolute errors")
    print(f"  {'noise px':>8} {'estimator':<10}{'roll':>8}{'pitch':>8}{'yaw':>8}{'dist cm':>9}")
    for level in cmp_["noise"]:
        for name in ("POSIT", "POSIT+GN", "SQPNP"):
            e = level[name]
            print(
                f"  {level['noise_px']:8g} {name:<10}{e['roll']['mae']:8.3f}"
                f"{e['pitch']['mae']:8.3f}{e['yaw']['mae']:8.3f}{e['distance_cm']['mae']:9.3f}"
            )
    seq = report["sequence"]
    print(
        f"\nsequence with model {seq['model']}, {seq['noise_px']:g} px noise: "
        f"{seq['estimated']}/{seq['frames']} frames reliable, {seq['unreliable']} unreliable"
    )
    print(f"  {'':<12}{'mean':>8}{'std':>8}{'mae':>8}{'max':>8}")
    for name, s in seq["errors"].items():
        print(f"  {name:<12}{s['mean']:8.2f}{s['std']:8.2f}{s['mae']:8.2f}{s['max_abs']:8.2f}")
    fits = report["aam_fits"]
    if fits is not None:
        print(
            f"\nend to end, POSIT on AAM fits: {fits['estimated']}/{fits['frames']} frames, "
            f"{fits['missing']} without a good fit ({fits['failed_fits']} failed eq. 7.2)"
        )
        print(f"  {'':<12}{'mean':>8}{'std':>8}{'mae':>8}{'max':>8}")
        for name, s in fits["errors"].items():
            print(f"  {name:<12}{s['mean']:8.2f}{s['std']:8.2f}{s['mae']:8.2f}{s['max_abs']:8.2f}")
    if report["plot"]:
        print(f"wrote {report['plot']}")
