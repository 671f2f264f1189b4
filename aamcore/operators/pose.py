"""The pose stage: the head pose of every face of a frame, from its landmarks, each face with
its own pose tracker (smoothing; with ``contour+calib`` a head model learned from it)."""

from __future__ import annotations

from collections.abc import Sequence

from aamcore.ar.cover import covered_points
from aamcore.operators.faces import NO_FACE, FaceFit, FacePose, FrameRef
from aamcore.operators.options import PIPELINE, PoseOptions
from aamcore.operators.per_face import FORGET_FRAMES, PerFace
from aamcore.pose import IntrinsicsError, PoseError
from aamcore.pose.estimator import Cameras, HeadPose, HeadPoseEstimator, HeadPoseTracker


class PoseOperator:
    """Head poses of a frame's fits (:class:`~aamcore.pose.estimator.HeadPoseTracker` per
    face).

    Parameters
    ----------
    options : PoseOptions
    forget_frames : int
        The fit stage's :attr:`~aamcore.fitting.config.NewFaces.forget_frames`.

    Raises
    ------
    IntrinsicsError, PoseError, OSError
        For a calibration file that cannot be used, or an estimator that cannot be made.
    """

    def __init__(self, options: PoseOptions = PIPELINE.pose,
                 forget_frames: int = FORGET_FRAMES) -> None:
        self.options = options
        self.cameras = Cameras(options.fov, options.calibration)
        self.faces = PerFace(self._tracker, HeadPoseTracker.reset, forget_frames=forget_frames,
                             lost=HeadPoseTracker.reset)
        self.estimator = self.faces.first.estimator
        """The first face's estimator (its method, head model and camera)."""

    def _tracker(self) -> HeadPoseTracker:
        estimator = HeadPoseEstimator(self.cameras, method=self.options.estimator)
        return HeadPoseTracker(estimator, self.options.smoothing)

    def __call__(self, frame: FrameRef, faces: Sequence[FaceFit]) -> list[FacePose]:
        """The pose of each face, or why there is none (no landmarks: the fit's reason, or
        the estimator's for landmarks it refuses); a failed fit's pose is unreliable."""
        return [self._pose(frame, face) for face in faces]

    def _pose(self, frame: FrameRef, face: FaceFit) -> FacePose:
        tracker = self.faces.of(face.face_id, frame.index)
        if not face.found:
            tracker.reset()
            return FacePose(face.face_id, reason=face.reason or NO_FACE)
        try:
            pose = tracker.update(face.points, frame.width, frame.height, frame.t, face.failed)
        except (PoseError, IntrinsicsError) as exc:
            return FacePose(face.face_id, reason=str(exc))
        return _face_pose(face, pose, self.cameras.source)

    def reset(self) -> None:
        """Forget every face (a new run)."""
        self.faces.clear()

    @property
    def refinements(self) -> int | None:
        """Head model refinements of the first face's calibration (None without one)."""
        calibration = self.estimator.calibration
        return None if calibration is None else calibration.refinements


def _face_pose(face: FaceFit, pose: HeadPose, camera: str) -> FacePose:
    est = pose.estimate
    reason = f"fit failed: {face.reason}" if face.failed else pose.reason
    roll, pitch, yaw = est.rpy
    covered = None if face.failed else covered_points(face.points, face.occluded)
    return FacePose(face.face_id, est.R, est.T, (float(roll), float(pitch), float(yaw)),
                    pose.camera.K, not reason, reason, int(est.iterations), pose.angle_sd_deg,
                    camera, covered)
