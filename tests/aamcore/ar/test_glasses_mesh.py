"""The glasses model and its placement on the OpenFace mean head."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.ar.glasses_mesh import (
    ANCHOR_NAMES,
    LENS_PARTS,
    OPAQUE_PARTS,
    GlassesDesign,
    build_glasses,
    mean_head_glasses,
)
from aamcore.pose.head_model import openface68


@pytest.fixture(scope="module")
def head() -> np.ndarray:
    return openface68().points


@pytest.fixture(scope="module")
def glasses():
    return mean_head_glasses()


def test_lenses_sit_on_the_eyes_in_front_of_the_nose_bridge(glasses, head) -> None:
    eyes = np.array([head[[36, 39]].mean(axis=0), head[[42, 45]].mean(axis=0)])
    np.testing.assert_allclose(glasses.lens_centres[:, :2], eyes[:, :2])
    assert np.all(glasses.lens_centres[:, 2] < head[27, 2])  # -z is toward the camera
    for name, centre in zip(("lens_right", "lens_left"), glasses.lens_centres, strict=True):
        lens = glasses.part_vertices(name)
        design = GlassesDesign()
        assert np.ptp(lens[:, 0]) == pytest.approx(2 * design.lens_half_width, rel=0.01)
        assert np.ptp(lens[:, 1]) == pytest.approx(2 * design.lens_half_height, rel=0.01)
        assert lens[:, :2].mean(axis=0) == pytest.approx(centre[:2], abs=0.5)
    assert glasses.lens_centres[0, 0] < 0 < glasses.lens_centres[1, 0]  # right lens at -x


def test_temples_run_back_outside_the_head(glasses, head) -> None:
    jaw_width = np.abs(head[[0, 16], 0]).max()
    for name, side in (("temple_right", -1.0), ("temple_left", 1.0)):
        temple = glasses.part_vertices(name)
        assert np.all(np.sign(temple[:, 0]) == side)
        behind = temple[temple[:, 2] > head[[0, 16], 2].max()]
        assert len(behind) and np.all(np.abs(behind[:, 0]) > jaw_width)
        assert temple[:, 2].max() - glasses.lens_centres[0, 2] > 100.0
        # the end bends down (+y) behind the ear
        end = temple[temple[:, 2] > temple[:, 2].max() - 5.0]
        hinge = temple[temple[:, 2] < temple[:, 2].min() + 3.0]
        assert end[:, 1].mean() - hinge[:, 1].mean() > 0.8 * GlassesDesign().temple_drop


def test_parts_cover_every_triangle_in_order(glasses) -> None:
    first = 0
    for name in OPAQUE_PARTS + LENS_PARTS:
        start, count = glasses.parts[name]
        assert start == first and count > 0
        first += count
    assert first == len(glasses.triangles)
    assert glasses.vertices.dtype == np.float32 and glasses.triangles.dtype == np.uint32
    np.testing.assert_allclose(np.linalg.norm(glasses.normals, axis=1), 1.0, rtol=1e-5)


def test_glasses_of_a_mirrored_head_are_mirrored(head) -> None:
    mirror = [16 - i for i in range(17)] + [26 - i for i in range(10)] + list(range(27, 31))
    mirror += [35 - i for i in range(5)] + [45, 44, 43, 42, 47, 46, 39, 38, 37, 36, 41, 40]
    mirror += [54, 53, 52, 51, 50, 49, 48, 59, 58, 57, 56, 55, 64, 63, 62, 61, 60, 67, 66, 65]
    flipped = head[mirror] * [-1.0, 1.0, 1.0]
    symmetric = 0.5 * (head + flipped)
    glasses = build_glasses(symmetric)
    for part in ("rim", "lens", "temple"):
        # ring vertices average to the centre line, so centroids mirror exactly
        right = glasses.part_vertices(f"{part}_right").mean(axis=0)
        left = glasses.part_vertices(f"{part}_left").mean(axis=0)
        np.testing.assert_allclose(right, left * [-1.0, 1.0, 1.0], atol=1e-3)
        assert right[0] < -10.0


def test_bad_landmarks_are_refused(head) -> None:
    with pytest.raises(ValueError, match=r"\(68, 3\)"):
        build_glasses(head[:, :2])
    bad = head.copy()
    bad[5, 1] = np.inf
    with pytest.raises(ValueError, match="finite"):
        build_glasses(bad)


def test_glasses_anchor_points() -> None:
    glasses = mean_head_glasses()
    anchors = glasses.anchor_points()
    assert anchors.shape == (len(ANCHOR_NAMES), 3) and np.all(np.isfinite(anchors))
    assert np.allclose(anchors[:2], glasses.lens_centres)
    right, left = anchors[3], anchors[4]
    assert right[0] < anchors[0, 0] < anchors[2, 0] < anchors[1, 0] < left[0]
    assert anchors[2, 1] < anchors[0, 1]  # the bridge is above the lens centres
    hinges = glasses.part_vertices("temple_right")
    assert np.linalg.norm(hinges - right, axis=1).min() < 3.0
