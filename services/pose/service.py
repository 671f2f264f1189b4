"""The head-pose service: the pose of each fit with landmarks, published as ``HeadPose``.

``aamtrack service pose [--fov DEG | --calibration FILE] [--estimator contour|posit|contour+calib]``

A thin wrapper over :class:`aamcore.pose.estimator.HeadPoseEstimator`: the
camera is read from a calibration file or assumed from a horizontal field of
view, at the size of the frame the fit was made on (the fit carries it). A
fit with landmarks gets a pose; when the fit itself failed, or the estimator
does not trust its answer (a face in profile, landmarks outside the frame or
that no head explains), the pose is published with ``reliable = False`` and
the reason. Fits without landmarks (no face) get none, nor do landmarks the
estimator refuses (PoseError: counted as dropped); the status line counts each reason.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Sequence

from aamcore.per_face import PerFace
from aamcore.pose import IntrinsicsError, PoseError
from aamcore.pose.estimator import Cameras, HeadPoseEstimator, HeadPoseTracker
from aamcore.pose.reliability import reason_key
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
    t = fit.header.media_time_ns / 1e9
    pose = poses.update(fit.landmarks, fit.image_width, fit.image_height, t, fit.failed)
    est, cam = pose.estimate, pose.camera
    roll, pitch, yaw = est.rpy
    reason = f"fit failed: {fit.failure_reason}" if fit.failed else pose.reason
    return HeadPose(
        svc.header_for(fit), est.R, est.T, float(roll), float(pitch), float(yaw), cam.K,
        fit.image_width, fit.image_height, poses.estimator.cameras.source,
        int(est.iterations), not reason, reason, pose.angle_sd_deg, fit.face_id,
    )


class FacePoses:
    """A pose tracker per face id (its smoothing, and with ``contour+calib`` its own head
    model learned online), :class:`aamcore.per_face.PerFace`."""

    def __init__(self, make: Callable[[], HeadPoseTracker]) -> None:
        self.faces = PerFace(make, HeadPoseTracker.reset)
        self.first = self.faces.first

    def of(self, fit: Fit) -> HeadPoseTracker:
        """The tracker of the face of ``fit``; a failed fit (no face tracked) restarts every
        face's, and takes the first's (as the library's one face)."""
        if fit.face_id < 0:
            self.reset()
            return self.first
        return self.faces.of(fit.face_id, fit.header.frame_index)

    def reset(self) -> None:
        """A frame without a face: every face's pose starts afresh."""
        for poses in self.faces.states():
            poses.reset()


class PoseCounts:
    """What the status line counts: fits without a face, unreliable poses and fits without
    a pose, by the short key of their reason."""

    def __init__(self) -> None:
        self.no_face = 0
        self.unreliable: Counter[str] = Counter()
        self.no_pose: Counter[str] = Counter()

    def line(self, refinements: int | None = None) -> str:
        """``"2 fits without a face; unreliable: 3 profile; no pose: 1 mostly out of ..."``,
        and the head model refinements since the face was found when there is a calibration."""
        parts = [f"{self.no_face} fits without a face"]
        if refinements is not None:
            parts.append(f"head model refined {refinements} times")
        for name, counts in (("unreliable", self.unreliable), ("no pose", self.no_pose)):
            if counts:
                parts.append(f"{name}: " + ", ".join(f"{n} {k}" for k, n in
                                                     counts.most_common(6)))
        return "; ".join(parts)


def answer(svc: Service, fit: Fit, faces: FacePoses, counts: PoseCounts) -> None:
    """Publish the pose of one fit (none for a fit without landmarks, or one the estimator
    refuses: counted by reason)."""
    if len(fit.landmarks) == 0:
        faces.reset()
        counts.no_face += 1
        return
    try:
        pose = pose_message(svc, fit, faces.of(fit))
    except (PoseError, IntrinsicsError, ProtoError) as exc:
        counts.no_pose[reason_key(str(exc))] += 1
        svc.stats.dropped += 1  # no pose can be had from these landmarks: none is owed
        return
    svc.publish(pose)
    if not pose.reliable:
        counts.unreliable[reason_key(pose.reason)] += 1


def serve(svc: Service, faces: FacePoses, capacity: int) -> None:
    """Estimate poses until stopped."""
    counts = PoseCounts()
    fits = svc.messages("fit", capacity=capacity)
    estimator = faces.first.estimator
    svc.ready(f"{estimator.method} on head model {estimator.model.name}, camera "
              f"{estimator.cameras.source}")
    for got in fits:
        fit = got.message
        assert isinstance(fit, Fit)
        with svc.answering(f"fit {fit.header.frame_index}"):
            answer(svc, fit, faces, counts)
        calib = estimator.calibration
        svc.set_state("running", counts.line(None if calib is None else calib.refinements))


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: ``python -m services.pose.service``."""
    args = parse_service_args(NAME, "Head pose from each fit.", PoseOptions, argv)
    log = init_process(NAME, args.verbose)
    opts: PoseOptions = args.options
    try:
        cameras = Cameras(opts.fov, opts.calibration)
        faces = FacePoses(lambda: HeadPoseTracker(
            HeadPoseEstimator(cameras, method=opts.estimator), opts.smooth))
    except (PoseError, IntrinsicsError, OSError) as exc:
        log.error("cannot set up head pose: %s", exc)
        return 1
    with Service(NAME, args.bus) as svc:
        serve(svc, faces, opts.capacity)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
