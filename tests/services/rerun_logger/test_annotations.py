"""Landmark schemes become Rerun classes: one per facial part, coloured, and one for failures."""

from __future__ import annotations

import numpy as np

from aamcore.io.landmarks import IBUG68
from services.rerun_logger.annotations import (
    FAILED_COLOUR,
    PART_COLOURS,
    PARTS,
    LandmarkClasses,
    class_description,
    keypoint_labels,
    resolve_scheme,
    scheme_classes,
    scheme_parts,
)

IBUG_PARTS = ("brows", "eyes", "nose", "mouth", "jaw")


def _rgba(colour: tuple[int, int, int]) -> int:
    r, g, b = colour
    return (r << 24) | (g << 16) | (b << 8) | 0xFF


def test_resolve_scheme_knows_ibug68_only_with_68_points():
    assert resolve_scheme("ibug68", 68) is IBUG68
    other = resolve_scheme("ibug68", 50)
    assert (other.name, other.n_points, other.edges) == ("ibug68", 50, ())
    imm = resolve_scheme("imm73", 73)
    assert (imm.n_points, imm.edges) == (73, ())


def test_keypoint_labels_name_the_coarse_group_of_each_point():
    labels = keypoint_labels(IBUG68)
    assert len(labels) == 68
    for group in IBUG_PARTS:
        for i in IBUG68.groups[group]:
            assert labels[i] == f"{group} {i}"
    assert keypoint_labels(resolve_scheme("x", 3)) == ["points 0", "points 1", "points 2"]


def test_the_parts_are_the_five_facial_parts_in_a_fixed_order():
    assert PARTS == IBUG_PARTS
    assert scheme_parts(IBUG68) == list(IBUG_PARTS)
    assert scheme_parts(resolve_scheme("x", 3)) == ["points"]
    assert len(set(PART_COLOURS.values()) | {FAILED_COLOUR}) == len(PARTS) + 1


def test_class_description_connects_the_edges_among_its_points():
    desc = class_description(IBUG68, 4, "ibug68", (1, 2, 3))
    assert desc.info.id == 4 and str(desc.info.label) == "ibug68"
    pairs = [(c.keypoint0.id, c.keypoint1.id) for c in desc.keypoint_connections]
    assert pairs == list(IBUG68.edges)
    assert [a.id for a in desc.keypoint_annotations] == list(range(68))
    assert str(desc.keypoint_annotations[48].label) == "mouth 48"
    eyes = class_description(IBUG68, 1, "eyes", (1, 2, 3), list(IBUG68.groups["eyes"]))
    assert [a.id for a in eyes.keypoint_annotations] == list(range(36, 48))
    pairs = {(c.keypoint0.id, c.keypoint1.id) for c in eyes.keypoint_connections}
    assert pairs == {(a, b) for a, b in IBUG68.edges if 36 <= a < 48}


def test_each_ibug_part_is_a_class_of_its_colour_with_its_own_edges():
    classes = scheme_classes(IBUG68, 0, "ibug68")
    assert classes.failed_id == 5 and len(classes.descriptions) == 6
    for k, part in enumerate(IBUG_PARTS):
        points = IBUG68.groups[part]
        assert set(np.flatnonzero(classes.part_ids == k)) == set(points), part
        desc = classes.descriptions[k]
        assert desc.info.id == k and str(desc.info.label) == f"ibug68 {part}"
        assert desc.info.color.rgba == _rgba(PART_COLOURS[part])
        assert {a.id for a in desc.keypoint_annotations} == set(points)
    # Every iBUG edge lies in one part: the parts together draw them all.
    drawn = {(c.keypoint0.id, c.keypoint1.id) for d in classes.descriptions[:5]
             for c in d.keypoint_connections}
    assert drawn == set(IBUG68.edges)
    failed = classes.descriptions[5]
    assert failed.info.color.rgba == _rgba(FAILED_COLOUR)
    assert len(failed.keypoint_annotations) == 68
    assert len(failed.keypoint_connections) == len(IBUG68.edges)
    assert list(classes.ids(failed=True)) == [5] * 68


def test_landmark_classes_number_the_classes_of_schemes_in_order_of_use():
    classes = LandmarkClasses()
    ids, new = classes.class_ids("ibug68", 68)
    assert new and list(ids[[0, 17, 27, 36, 48]]) == [4, 0, 2, 1, 3]  # jaw, brows, nose, ...
    ids, new = classes.class_ids("ibug68", 68, failed=True)
    assert not new and set(ids) == {5}
    ids, new = classes.class_ids("imm73", 73, failed=True)
    assert new and set(ids) == {7}
    ids, new = classes.class_ids("imm73", 73)
    assert not new and set(ids) == {6}
    assert set(classes.class_ids("ibug68", 68)[0]) == {0, 1, 2, 3, 4}
    (classes_logged,) = classes.context().context.as_arrow_array().to_pylist()
    assert [c["class_id"] for c in classes_logged] == list(range(8))
    labels = [c["class_description"]["info"]["label"] for c in classes_logged]
    assert labels == [*(f"ibug68 (68 points) {p}" for p in IBUG_PARTS),
                      "ibug68 (68 points), failed",
                      "imm73 (73 points) points", "imm73 (73 points), failed"]
