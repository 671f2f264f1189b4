"""Faces that change shape: expression targets and the piecewise-affine warp that makes a
photo take them, the surrounding image carried along."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from aamcore.io import load_annotated_folder
from aamcore.io.splits import split
from aamcore.model.similarity import Similarity
from aamcore.synth.deform import ExpressionSpec, expression_shapes, reshape
from aamcore.synth.motion import SIZE, MotionSpec, generate


def held_out(lfpw_dir: Path, count: int):
    _, test = split(load_annotated_folder(lfpw_dir).samples, "lfpw")
    return test[:count]


def test_expressions_move_the_jaw_mouth_brows_and_lids(lfpw_dir: Path) -> None:
    face, *others = held_out(lfpw_dir, 3)
    shapes = expression_shapes(face.points, [o.points for o in others], 90,
                               ExpressionSpec(seed=4))
    assert shapes.shape == (90, 68, 2) and np.all(np.isfinite(shapes))
    iod = np.linalg.norm(face.points[45] - face.points[36])
    moved = np.linalg.norm(shapes - face.points, axis=2).max(axis=0) / iod
    for part in (range(4, 13), range(55, 60), range(17, 27), (37, 38, 43, 44)):
        assert moved[list(part)].max() > 0.05, part
    # the mouth opens: the lower lip leaves the upper one, and closes again
    gap = np.linalg.norm(shapes[:, 66] - shapes[:, 62], axis=1)
    assert gap.max() - gap.min() > 0.15 * iod
    # the same seed, the same shapes
    again = expression_shapes(face.points, [o.points for o in others], 90,
                              ExpressionSpec(seed=4))
    np.testing.assert_array_equal(shapes, again)


def test_a_warp_to_the_same_shape_changes_nothing_and_one_to_another_moves_the_face(
    lfpw_dir: Path,
) -> None:
    face = held_out(lfpw_dir, 1)[0]
    photo = face.load_image()
    sim = Similarity.from_estimate(face.points, face.points * 0.5 + [100, 40])
    placed = cv2.warpAffine(photo, sim.matrix, SIZE)
    source = sim.apply(face.points)
    same = reshape(placed.copy(), photo, sim, source, source)
    assert np.abs(same.astype(int) - placed.astype(int)).mean() < 1.0
    target = source.copy()
    target[8] += [0, 12]  # the chin down
    dropped = reshape(placed.copy(), photo, sim, source, target)
    mask = np.ones(placed.shape[:2], np.uint8)
    cv2.circle(mask, tuple(source.mean(axis=0).astype(int).tolist()),
               int(1.2 * np.ptp(source, axis=0).max()), 0, -1)
    far = mask > 0
    assert np.array_equal(dropped[far], placed[far])  # outside the ring: as it was
    x, y = np.round(source[8]).astype(int)
    assert np.abs(dropped[y - 3:y + 12, x - 3:x + 4].astype(int)
                  - placed[y - 3:y + 12, x - 3:x + 4].astype(int)).mean() > 2.0


def test_a_generated_non_rigid_sequence_has_the_warped_shapes_as_truth(lfpw_dir: Path) -> None:
    face, other = held_out(lfpw_dir, 2)
    spec = MotionSpec(frames=6, max_angle_deg=10.0, scales=(0.9, 1.1), seed=2)
    shapes = expression_shapes(face.points, [other.points], 6, ExpressionSpec(seed=2))
    rigid = generate(face.load_image(), face.points, spec)
    moving = generate(face.load_image(), face.points, spec, shapes)
    for k in range(6):
        sim = Similarity.from_estimate(face.points, rigid.landmarks[k])
        np.testing.assert_allclose(moving.landmarks[k], sim.apply(shapes[k]), atol=1e-6)
    assert any(np.abs(a.astype(int) - b.astype(int)).mean() > 0.5
               for a, b in zip(rigid.frames, moving.frames, strict=True))
