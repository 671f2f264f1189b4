"""aamcore.evaluation.pose_scores: errors, anchors, reasons and timing of real estimators."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.ar.glasses_mesh import mean_head_glasses
from aamcore.evaluation.pose_scores import anchor_reprojection_px, evaluate_estimator
from aamcore.evaluation.pose_sweeps import SweepSpec, tracked_sweeps
from aamcore.pose.calibrate import OnlineCalibration
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.robust import ContourPose
from aamcore.synth.sequence import PoseTruth

CAM = CameraIntrinsics.from_fov(640, 480, 60.0)
ANCHORS = mean_head_glasses().anchor_points()


@pytest.fixture(scope="module")
def contour() -> ContourPose:
    return ContourPose()


def own_landmarks(contour: ContourPose, poses: list[PoseTruth]) -> list[np.ndarray | None]:
    """Exact landmarks of the estimator's own head (jaw on its outline)."""
    out: list[np.ndarray | None] = []
    for p in poses:
        uv = CAM.project(contour.X, p.R, p.T)
        jaw, _, _ = contour.outline.silhouette(p.R, p.T, CAM.K)
        uv[:17] = CAM.project(jaw, p.R, p.T)
        out.append(uv)
    return out


def test_anchor_error_is_zero_at_the_truth_and_grows_with_a_shift() -> None:
    truth = PoseTruth(np.eye(3), np.array([0.0, 0.0, 600.0]))
    assert anchor_reprojection_px(ANCHORS, CAM, truth, truth) == 0.0  # type: ignore[arg-type]
    moved = PoseTruth(np.eye(3), np.array([1.0, 0.0, 600.0]))
    px = anchor_reprojection_px(ANCHORS, CAM, moved, truth)  # type: ignore[arg-type]
    assert px == pytest.approx(CAM.K[0, 0] / 600.0, rel=0.05)


def test_exact_landmarks_score_zero_and_bad_frames_are_counted(contour: ContourPose) -> None:
    sweeps = tracked_sweeps(None, "none", CAM, (SweepSpec("yaw60", "yaw", 8, 60.0),))
    marks = own_landmarks(contour, sweeps[0].poses)
    marks[2] = None
    bad = marks[3]
    assert bad is not None
    marks[3] = np.full((68, 2), np.nan)
    marks[5] = bad[np.random.default_rng(0).permutation(68)]
    ticks = iter(np.arange(100) * 0.002)  # a clock that moves 2 ms each time it is read
    results, timing = evaluate_estimator(contour.estimate, sweeps, CAM, ANCHORS, [marks],
                                         clock=lambda: float(next(ticks)))
    r = results["yaw60"]
    assert (r.frames, r.estimated, r.no_pose, r.unreliable) == (8, 5, 2, 1)
    assert r.reasons["no landmarks"] == 1 and r.reasons["too few landmarks"] == 1
    assert r.errors["yaw"]["max_abs"] < 1e-3 and r.anchor_px_max < 1e-3
    # Yaw 0, 42, 60, 42, 0, -42, -60, -42: the frame at +60 had no landmarks.
    assert r.covered == pytest.approx((-60.0, 60.0 * np.sin(np.pi / 4)))
    assert results["all"].estimated == 5 and timing["calls"] == 7.0
    # each estimate timed between two readings of the clock, outside the estimator
    assert timing["ms_median"] == pytest.approx(2.0) and timing["ms_p99"] == pytest.approx(2.0)


def test_a_background_estimator_is_settled_outside_the_timing() -> None:
    sweeps = tracked_sweeps(None, "none", CAM, (SweepSpec("yaw60", "yaw", 30, 60.0),))
    calib = OnlineCalibration()
    marks = own_landmarks(calib.current, sweeps[0].poses)
    results, _ = evaluate_estimator(calib.estimate, sweeps, CAM, ANCHORS, [marks],
                                    settle=calib.wait)
    assert calib.refinements >= 1 and not calib.pending
    assert results["yaw60"].estimated == 30 and results["yaw60"].errors["yaw"]["max_abs"] < 0.5
