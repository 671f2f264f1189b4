"""Headless rendering: the GL projection agrees with OpenCV's, landmarks land on the face."""

from __future__ import annotations

import threading
from collections.abc import Iterator

import cv2
import numpy as np
import pytest

from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.rotation import rotation_angle_deg, rotation_from_rpy
from aamcore.synth.head import synth_head
from aamcore.synth.renderer import HeadRenderer, opengl_projection
from aamcore.synth.texture import FaceTexture

CAM = CameraIntrinsics.from_fov(640, 480, 60.0)
POSES = [((0, 0, 0), 600.0), ((0, 0, 40), 600.0), ((0, -35, 0), 500.0), ((30, 15, -25), 450.0),
         ((-20, 30, 35), 1100.0)]


@pytest.fixture(scope="module")
def renderer(texture: FaceTexture) -> Iterator[HeadRenderer]:
    with HeadRenderer(synth_head(), texture, CAM) as r:
        yield r


def pose(rpy: tuple[float, float, float], distance: float) -> tuple[np.ndarray, np.ndarray]:
    return rotation_from_rpy(*rpy), np.array([25.0, -15.0, distance])


def test_projection_matrix_matches_opencv() -> None:
    cam = CameraIntrinsics(np.array([[500.0, 0, 300.0], [0, 520.0, 250.0], [0, 0, 1]]), None,
                           640, 480)
    point = np.array([40.0, -30.0, 700.0])
    clip = opengl_projection(cam) @ np.append(point, 1.0)
    ndc = clip[:3] / clip[3]
    window = (ndc[:2] + 1.0) / 2.0 * [640, 480]  # GL window coordinates
    assert np.allclose(window - 0.5, cam.project(point[None], np.eye(3), np.zeros(3))[0])


@pytest.mark.parametrize("rpy, distance", POSES)
def test_silhouette_is_where_opencv_projects_the_mesh(
    renderer: HeadRenderer, rpy: tuple[float, float, float], distance: float
) -> None:
    R, T = pose(rpy, distance)
    frame = renderer.render(R, T)
    ys, xs = np.nonzero(frame.mask)
    projected = CAM.project(synth_head().mesh.vertices, R, T)
    assert xs.min() == pytest.approx(projected[:, 0].min(), abs=1.0)
    assert xs.max() == pytest.approx(projected[:, 0].max(), abs=1.0)
    assert ys.min() == pytest.approx(projected[:, 1].min(), abs=1.0)
    assert ys.max() == pytest.approx(projected[:, 1].max(), abs=1.0)
    # Off the head (one pixel away from its anti-aliased edge) is plain background.
    background = cv2.erode((~frame.mask).astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
    assert np.all(frame.image[background] == renderer.background)
    assert np.mean(np.all(frame.image[frame.mask] == renderer.background, axis=1)) < 0.01


@pytest.mark.parametrize("rpy, distance", POSES)
def test_landmarks_fall_on_the_rendered_face(
    renderer: HeadRenderer, rpy: tuple[float, float, float], distance: float
) -> None:
    head = synth_head()
    R, T = pose(rpy, distance)
    frame = renderer.render(R, T)
    uv = CAM.project(head.landmarks_3d, R, T)
    px = np.round(uv).astype(int)
    on_face = cv2.dilate(frame.mask.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
    assert np.all(on_face[px[:, 1], px[:, 0]])
    # Where a landmark is the visible surface, the depth buffer holds its depth: the
    # renderer and CameraIntrinsics.project put it on the same pixel.
    z = (head.landmarks_3d @ R.T + T)[:, 2]
    depth = frame.depth[px[:, 1], px[:, 0]]
    visible = np.abs(depth - z) < 3.0
    assert visible.sum() >= 40
    inner = np.arange(17, 68)  # off the outline, where one pixel can be background
    hidden = inner[~visible[inner]]
    assert np.all(depth[hidden] < z[hidden] + 5.0)  # not visible: something in front of it


@pytest.mark.parametrize("rpy, distance", POSES)
def test_posit_recovers_the_rendered_pose(
    renderer: HeadRenderer, rpy: tuple[float, float, float], distance: float
) -> None:
    head = synth_head()
    R, T = pose(rpy, distance)
    uv = CAM.project(head.landmarks_3d, R, T)
    est = head.head_model().posit().estimate(uv, CAM)
    assert est.reliable and rotation_angle_deg(est.R, R) < 1.0
    assert np.linalg.norm(est.T - T) < 5.0


def test_renders_in_a_worker_thread(texture: FaceTexture) -> None:
    """A context made in a worker thread renders there (the documented use)."""
    out: dict[str, object] = {}

    def work() -> None:
        try:
            small = CAM.scaled_to(160, 120)
            with HeadRenderer(synth_head(), texture, small) as r:
                out["mask"] = r.render(np.eye(3), np.array([0.0, 0.0, 600.0])).mask
        except Exception as exc:  # reported to the test thread
            out["error"] = exc

    thread = threading.Thread(target=work)
    thread.start()
    thread.join(timeout=60)
    assert "error" not in out, out.get("error")
    mask = out["mask"]
    assert isinstance(mask, np.ndarray) and mask.shape == (120, 160) and 300 < mask.sum() < 5000
