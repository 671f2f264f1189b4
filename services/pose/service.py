"""The head-pose service: the pose of each fit with landmarks, published as ``HeadPose``.

``aamtrack service pose [--fov DEG | --calibration FILE]``

A thin wrapper over :class:`aamcore.pose.estimator.HeadPoseEstimator`: the
camera is read from a calibration file or assumed from a horizontal field of
view, at the size of the frame the fit was made on (the fit carries it). A
fit with landmarks gets a pose; when the fit itself failed, the pose is
published flagged ``reliable = False``. Fits without landmarks (no face) get
none.
"""

from __future__ import annotations

from collections.abc import Sequence

from aamcore.pose import IntrinsicsError, PoseError
from aamcore.pose.estimator import Cameras, HeadPoseEstimator, HeadPoseTracker
from proto import Fit, HeadPose, ProtoError
from services.bus.args import parse_service_args
from services.bus.process import init_process
from services.bus.session import Service
from services.pose.options import PoseOptions

NAME = "pose"


def pose_message(svc: Service, fit: Fit, poses: HeadPoseTracker) -> HeadPose:
    """The pose message of one fit with landmarks.

    Raises
    ------
    PoseError, IntrinsicsError
        When no pose can be estimated from it.
    """
    t = fit.header.capture_time_ns / 1e9
    pose = poses.update(fit.landmarks, fit.image_width, fit.image_height, t, fit.failed)
    est, cam = pose.estimate, pose.camera
    roll, pitch, yaw = est.rpy
    reason = f"fit failed: {fit.failure_reason}" if fit.failed else pose.reason
    return HeadPose(
        svc.header_for(fit), est.R, est.T, float(roll), float(pitch), float(yaw), cam.K,
        fit.image_width, fit.image_height, poses.estimator.cameras.source,
        int(est.iterations), not reason, reason, pose.angle_sd_deg,
    )


def serve(svc: Service, poses: HeadPoseTracker, capacity: int) -> None:
    """Estimate poses until stopped."""
    no_face = 0
    fits = svc.messages("fit", capacity=capacity)
    estimator = poses.estimator
    svc.ready(f"head model {estimator.model.name}, camera {estimator.cameras.source}")
    for got in fits:
        fit = got.message
        assert isinstance(fit, Fit)
        if len(fit.landmarks) == 0:
            poses.reset()
            no_face += 1
            svc.set_state("running", f"{no_face} fits without a face")
            continue
        try:
            svc.publish(pose_message(svc, fit, poses))
        except (PoseError, IntrinsicsError, ProtoError) as exc:
            svc.reject("fit", f"no pose: {exc}")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: ``python -m services.pose.service``."""
    args = parse_service_args(NAME, "Head pose (POSIT) from each fit.", PoseOptions, argv)
    log = init_process(NAME, args.verbose)
    opts: PoseOptions = args.options
    try:
        poses = HeadPoseTracker(HeadPoseEstimator(Cameras(opts.fov, opts.calibration)),
                                opts.smooth)
    except (PoseError, IntrinsicsError, OSError) as exc:
        log.error("cannot set up head pose: %s", exc)
        return 1
    with Service(NAME, args.bus) as svc:
        serve(svc, poses, opts.capacity)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
