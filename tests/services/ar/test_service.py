"""services.ar.service: glasses composited on a frame at a pose, overlays raw and JPEG."""

from __future__ import annotations

import time
from collections.abc import Iterator

import moderngl
import numpy as np
import pytest

from aamcore.operators.overlay import OverlayOperator
from aamcore.pose import CameraIntrinsics
from proto import Frame, Header, HeadPose, decode, encode
from services.ar.service import overlay_message
from services.bus.connection import BusOptions
from services.bus.images import image_of
from services.bus.session import Service
from services.messages import pose_of


@pytest.fixture(scope="module")
def overlay() -> Iterator[OverlayOperator]:
    ctx = moderngl.create_standalone_context(backend="egl")
    op = OverlayOperator(ctx=ctx)
    yield op
    op.close()
    ctx.release()


@pytest.fixture(scope="module")
def svc() -> Iterator[Service]:
    with Service("ar", BusOptions("cam0"), handle_signals=False) as s:
        yield s


def frontal_pose(width: int, height: int, distance_mm: float = 600.0) -> HeadPose:
    cam = CameraIntrinsics.from_fov(width, height, 60.0)
    return HeadPose(Header.now("cam0", 2, "pose", capture_time_ns=77), np.eye(3),
                    np.array([0.0, 0.0, distance_mm]), 0.0, 0.0, 0.0, cam.K, width, height,
                    "assumed:fov60", 3, True, "", 0.5)


def test_glasses_are_drawn_around_the_eyes_and_nowhere_far_away(
        overlay: OverlayOperator) -> None:
    frame = np.full((360, 640, 3), 180, np.uint8)
    out = overlay(frame, [pose_of(frontal_pose(640, 360))])
    changed = np.any(out != frame, axis=2)
    ys, xs = np.nonzero(changed)
    assert changed.sum() > 2000
    assert abs(xs.mean() - 320) < 40 and abs(ys.mean() - 180) < 60
    assert not changed[:, :150].any() and not changed[:, -150:].any()
    assert overlay(np.zeros((120, 160, 3), np.uint8),
                   [pose_of(frontal_pose(160, 120))]).shape == (120, 160, 3)


def test_overlay_messages_raw_and_jpeg(svc: Service) -> None:
    image = np.random.default_rng(1).integers(0, 255, (36, 64, 3), np.uint8)
    pose = frontal_pose(64, 36)
    raw = decode(encode(overlay_message(svc, pose, image, 0)), "overlay")
    assert raw.encoding == "raw" and np.array_equal(raw.image, image)
    assert raw.header.frame_index == 2 and raw.header.capture_time_ns == 77
    jpeg = decode(encode(overlay_message(svc, pose, image, 90)), "overlay")
    assert jpeg.encoding == "jpeg" and image_of(jpeg).shape == (36, 64, 3)


def test_a_frame_is_kept_until_a_pose_of_a_later_frame_comes(svc: Service) -> None:
    """Frames wait for their poses however far behind the poses are (within the store's
    bounds); a pose of frame k means none comes for the frames before it."""
    frames = svc.frame_store(count=100)  # delivered within the session
    last = 80
    for i in range(last + 1):
        header = Header.now(svc.stream, i, "source")
        svc.publish(Frame.from_array(header, np.zeros((4, 4, 3), np.uint8)))
    deadline = time.monotonic() + 5
    while frames.take("", last, keep=True) is None:
        assert time.monotonic() < deadline, "the frames did not arrive"
        time.sleep(0.01)
    assert len(frames) == last + 1 and frames.pushed_out == 0
    assert frames.take("", 0, keep=True) is not None  # the oldest is still there
    frames.forget_before("", 40)
    assert frames.forgotten == 40 and frames.take("", 39) is None
    assert frames.take("", 40) is not None and frames.take("", 40) is None  # taken once
