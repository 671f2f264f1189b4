"""The occluding head: MediaPipe face placed on the mean head, plus the skull ellipsoid."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.ar.glasses_mesh import mean_head_glasses
from aamcore.ar.head_occluder import (
    MEDIAPIPE_TO_IBUG,
    SKULL_CENTRE,
    SKULL_RADII,
    build_head_occluder,
    mean_head_occluder,
)
from aamcore.pose.head_model import openface68


@pytest.fixture(scope="module")
def occluder():
    return mean_head_occluder()


def test_face_mesh_lands_on_the_mean_landmarks(occluder) -> None:
    head = openface68().points
    assert occluder.fit_rms < 6.0  # mm; measured 4.0
    face = occluder.mesh.vertices
    for mp_index, ibug in MEDIAPIPE_TO_IBUG.items():
        if ibug in (36, 39, 42, 45, 27):  # eye corners and nose bridge: rigid, well marked
            assert np.linalg.norm(face[mp_index] - head[ibug]) < 6.0


def test_the_head_stays_behind_the_lenses(occluder) -> None:
    glasses = mean_head_glasses()
    head = occluder.mesh.vertices
    for name in ("lens_right", "lens_left", "bridge"):
        part = glasses.part_vertices(name)
        lo, hi = part[:, :2].min(axis=0), part[:, :2].max(axis=0)
        over = head[np.all((head[:, :2] >= lo) & (head[:, :2] <= hi), axis=1)]
        # the nose may rise between the lenses' lower inner corners, not over their middle
        near_centre = over[np.abs(over[:, 1] - part[:, 1].mean()) < 8.0]
        assert near_centre[:, 2].min() > part[:, 2].max(), name


def test_the_skull_stays_inside_the_temples() -> None:
    glasses = mean_head_glasses()
    centre, radii = np.array(SKULL_CENTRE), np.array(SKULL_RADII)
    for name in ("temple_right", "temple_left"):
        temple = glasses.part_vertices(name)
        assert np.all(np.sum(((temple - centre) / radii) ** 2, axis=1) > 1.0), name


def test_bad_landmarks_are_refused() -> None:
    with pytest.raises(ValueError, match="68, 3"):
        build_head_occluder(np.zeros((10, 3)))
