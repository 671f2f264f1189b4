"""The head-pose service: a thin adapter around the pose stage's operator
(:class:`aamcore.operators.pose.PoseOperator`), a ``HeadPose`` for each fit with landmarks.

``aamtrack service pose [--fov DEG | --calibration FILE] [--estimator contour|posit|contour+calib]``

A failed fit's pose, or one the estimator does not trust (a face in profile, landmarks
outside the frame or that no head explains), is published with ``reliable = False`` and
the reason. Fits without landmarks (no face) get none, nor do landmarks the estimator
refuses (counted as dropped); the status line counts each reason.
"""

from __future__ import annotations

from collections.abc import Sequence

from aamcore.operators.pose import PoseOperator
from aamcore.pose import IntrinsicsError, PoseError
from proto import Fit, ProtoError
from services.bus.args import parse_service_args
from services.bus.process import init_process
from services.bus.session import Service
from services.bus.stats import ReasonCounts
from services.messages import face_of, frame_of, pose_message
from services.pose.options import PoseOptions

NAME = "pose"


class PoseCounts:
    """What the status line counts: fits without a face, unreliable poses and fits without
    a pose, by the short key of their reason."""

    def __init__(self) -> None:
        self.no_face = 0
        self.unreliable, self.no_pose = ReasonCounts(), ReasonCounts()

    def line(self, refinements: int | None = None) -> str:
        """``"2 fits without a face; unreliable: 3 profile; no pose: 1 mostly out of ..."``,
        and the head model refinements since the face was found when there is a calibration."""
        parts = [f"{self.no_face} fits without a face"]
        if refinements is not None:
            parts.append(f"head model refined {refinements} times")
        parts += [f"{name}: {counts.line()}" for name, counts in
                  (("unreliable", self.unreliable), ("no pose", self.no_pose)) if counts.total()]
        return "; ".join(parts)


def answer(svc: Service, fit: Fit, op: PoseOperator, counts: PoseCounts) -> None:
    """Publish the pose of one fit (none for a fit without landmarks, or one the estimator
    refuses: counted by reason)."""
    [pose] = op(frame_of(fit), [face_of(fit)])
    if not len(fit.landmarks):
        counts.no_face += 1
    elif not pose.found:
        counts.no_pose.add(pose.reason)
        svc.stats.dropped += 1  # no pose can be had from these landmarks: none is owed
    else:
        try:
            svc.publish(pose_message(svc, fit, pose))
        except ProtoError as exc:
            counts.no_pose.add(str(exc))
            svc.stats.dropped += 1
            return
        if not pose.reliable:
            counts.unreliable.add(pose.reason)


def serve(svc: Service, op: PoseOperator, capacity: int) -> None:
    """Estimate poses until stopped."""
    counts = PoseCounts()
    fits = svc.messages("fit", capacity=capacity)
    svc.ready(f"{op.estimator.method} on head model {op.estimator.model.name}, camera "
              f"{op.cameras.source}")
    for got in fits:
        fit = got.message
        assert isinstance(fit, Fit)
        with svc.answering(f"fit {fit.header.frame_index}"):
            answer(svc, fit, op, counts)
        svc.set_state("running", counts.line(op.refinements))


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: ``python -m services.pose.service``."""
    args = parse_service_args(NAME, "Head pose from each fit.", PoseOptions, argv)
    log = init_process(NAME, args.verbose)
    try:
        op = PoseOperator(args.options.pose, args.options.new_faces.forget_frames)
    except (PoseError, IntrinsicsError, OSError) as exc:
        log.error("cannot set up head pose: %s", exc)
        return 1
    with Service(NAME, args.bus) as svc:
        serve(svc, op, args.options.capacity)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
