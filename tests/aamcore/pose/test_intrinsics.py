"""Camera intrinsics from calibration files and from an assumed field of view."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from aamcore.pose.errors import IntrinsicsError
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.rotation import rotation_from_rpy

K = np.array([[612.5, 0.0, 318.2], [0.0, 610.1, 241.7], [0.0, 0.0, 1.0]])
DIST = np.array([0.11, -0.23, 0.001, -0.002, 0.05])


def write_opencv(path: Path, with_size: bool = True, dist: np.ndarray = DIST) -> None:
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    if with_size:
        fs.write("image_width", 640)
        fs.write("image_height", 480)
    fs.write("camera_matrix", K)
    fs.write("distortion_coefficients", dist.reshape(-1, 1))
    fs.release()


def test_from_fov_states_its_assumption() -> None:
    cam = CameraIntrinsics.from_fov(640, 480, 60.0)
    assert cam.focal == pytest.approx((320 / np.tan(np.radians(30)),) * 2)
    assert cam.K[0, 2] == pytest.approx(319.5) and cam.K[1, 2] == pytest.approx(239.5)
    assert cam.horizontal_fov_deg == pytest.approx(60.0)
    assert "assumed" in cam.source and "60" in cam.source
    assert not cam.has_distortion
    with pytest.raises(IntrinsicsError, match="field of view"):
        CameraIntrinsics.from_fov(640, 480, 0.0)


@pytest.mark.parametrize("suffix", [".yaml", ".yml", ".xml"])
def test_reads_opencv_calibration_files(tmp_path: Path, suffix: str) -> None:
    path = tmp_path / f"calib{suffix}"
    write_opencv(path)
    cam = CameraIntrinsics.from_file(path)
    assert np.allclose(cam.K, K) and np.allclose(cam.dist, DIST)
    assert (cam.width, cam.height) == (640, 480)
    assert cam.source == str(path)
    assert cam.has_distortion


def test_reads_json_forms(tmp_path: Path) -> None:
    plain = tmp_path / "plain.json"
    plain.write_text(json.dumps({"camera_matrix": K.tolist(), "distortion_coefficients":
                                 DIST.tolist(), "image_width": 640, "image_height": 480}))
    cam = CameraIntrinsics.from_file(plain)
    assert np.allclose(cam.K, K) and np.allclose(cam.dist, DIST)
    opencv_style = tmp_path / "ocv.json"
    opencv_style.write_text(json.dumps({
        "camera_matrix": {"rows": 3, "cols": 3, "dt": "d", "data": K.ravel().tolist()},
        "image_width": 640, "image_height": 480}))
    cam = CameraIntrinsics.from_file(opencv_style)
    assert np.allclose(cam.K, K) and cam.dist.size == 0


@pytest.mark.parametrize("suffix", [".json", ".yaml", ".xml"])
def test_save_and_read_back(tmp_path: Path, suffix: str) -> None:
    cam = CameraIntrinsics(K, DIST, 640, 480, "test")
    cam.save(tmp_path / f"c{suffix}")
    back = CameraIntrinsics.from_file(tmp_path / f"c{suffix}")
    assert np.allclose(back.K, K) and np.allclose(back.dist, DIST)
    assert (back.width, back.height) == (640, 480)


def test_unparsable_files_raise_clear_errors(tmp_path: Path) -> None:
    bad_yaml = tmp_path / "bad.yaml"
    bad_yaml.write_text("%YAML:1.0\ncamera_matrix: [1, 2\n  ]]] : :\n")
    with pytest.raises(IntrinsicsError, match=r"bad\.yaml"):
        CameraIntrinsics.from_file(bad_yaml)
    bad_json = tmp_path / "bad.json"
    bad_json.write_text("{camera_matrix: nope")
    with pytest.raises(IntrinsicsError, match="does not parse as JSON"):
        CameraIntrinsics.from_file(bad_json)
    with pytest.raises(IntrinsicsError, match="not found"):
        CameraIntrinsics.from_file(tmp_path / "missing.yaml")
    with pytest.raises(IntrinsicsError, match="unknown calibration format"):
        (tmp_path / "c.txt").write_text("1 2 3")
        CameraIntrinsics.from_file(tmp_path / "c.txt")


def test_missing_keys_and_bad_values(tmp_path: Path) -> None:
    no_k = tmp_path / "nok.yaml"
    fs = cv2.FileStorage(str(no_k), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", 640)
    fs.release()
    with pytest.raises(IntrinsicsError, match="camera_matrix"):
        CameraIntrinsics.from_file(no_k)
    no_size = tmp_path / "nosize.yaml"
    write_opencv(no_size, with_size=False)
    with pytest.raises(IntrinsicsError, match="image_width"):
        CameraIntrinsics.from_file(no_size)
    assert CameraIntrinsics.from_file(no_size, 640, 480).width == 640
    with pytest.raises(IntrinsicsError, match="outside"):
        CameraIntrinsics.from_file(no_size, 320, 240)  # calibrated at another resolution
    with pytest.raises(IntrinsicsError, match="distortion"):
        CameraIntrinsics(K, np.zeros(3), 640, 480)
    with pytest.raises(IntrinsicsError, match="focal"):
        CameraIntrinsics(np.diag([-1.0, 1.0, 1.0]), None, 640, 480)
    with pytest.raises(IntrinsicsError, match="form"):
        CameraIntrinsics(np.ones((3, 3)), None, 640, 480)
    huge = np.array([[1e300, 0.0, 320.0], [0.0, 1e300, 240.0], [0.0, 0.0, 1.0]])
    with pytest.raises(IntrinsicsError, match="fx=1e.300 px is not 0.005 to 100 times"):
        CameraIntrinsics(huge, None, 640, 480)
    with pytest.raises(IntrinsicsError, match="fy=0.001"):
        CameraIntrinsics(np.array([[500.0, 0, 320], [0, 1e-3, 240], [0, 0, 1]]), None, 640, 480)
    with pytest.raises(IntrinsicsError, match="distortion coefficient of 1e.06"):
        CameraIntrinsics(K, np.array([1e6, 0, 0, 0, 0.0]), 640, 480)


def test_normalize_undoes_project_with_distortion() -> None:
    cam = CameraIntrinsics(K, DIST, 640, 480)
    rng = np.random.default_rng(1)
    pts = rng.uniform(-120, 120, (30, 3))
    R, T = rotation_from_rpy(5, -10, 20), np.array([10.0, -5.0, 300.0])
    uv = cam.project(pts, R, T)
    cam_pts = pts @ R.T + T
    assert np.allclose(cam.normalize(uv), cam_pts[:, :2] / cam_pts[:, 2:], atol=1e-8)
    ideal = CameraIntrinsics(K, None, 640, 480)
    assert not np.allclose(ideal.project(pts, R, T), uv, atol=0.5)  # distortion matters here


def test_scaled_to_keeps_the_field_of_view() -> None:
    cam = CameraIntrinsics.from_fov(1280, 720, 70.0)
    half = cam.scaled_to(640, 360)
    assert half.horizontal_fov_deg == pytest.approx(70.0)
    assert half.K[0, 2] == pytest.approx(319.5)


@pytest.mark.parametrize("width", [".nan", "-640", "640.5"])
def test_image_size_must_be_a_positive_whole_number(tmp_path: Path, width: str) -> None:
    path = tmp_path / "cam.yaml"
    path.write_text(f"%YAML:1.0\n---\nimage_width: {width}\nimage_height: 480\n"
                    "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                    "   data: [ 500., 0., 320., 0., 500., 240., 0., 0., 1. ]\n")
    with pytest.raises(IntrinsicsError, match="image_width is .*not a positive whole number"):
        CameraIntrinsics.from_file(path)
    (tmp_path / "cam.json").write_text(
        f'{{"image_width": {"NaN" if width == ".nan" else width}, "image_height": 480, '
        '"camera_matrix": [[500, 0, 320], [0, 500, 240], [0, 0, 1]]}')
    with pytest.raises(IntrinsicsError, match="image_width is .*not a positive whole number"):
        CameraIntrinsics.from_file(tmp_path / "cam.json")


def test_image_size_that_is_text_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "cam.yaml"
    path.write_text("%YAML:1.0\n---\nimage_width: NaN\nimage_height: 480\n"
                    "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                    "   data: [ 500., 0., 320., 0., 500., 240., 0., 0., 1. ]\n")
    with pytest.raises(IntrinsicsError, match="image_width is not a number"):
        CameraIntrinsics.from_file(path)
