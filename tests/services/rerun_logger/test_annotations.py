"""Landmark schemes become Rerun classes with keypoint labels and connections."""

from __future__ import annotations

from aamcore.io.landmarks import IBUG68
from services.rerun_logger.annotations import (
    LandmarkClasses,
    class_description,
    keypoint_labels,
    resolve_scheme,
)


def test_resolve_scheme_knows_ibug68_only_with_68_points():
    assert resolve_scheme("ibug68", 68) is IBUG68
    other = resolve_scheme("ibug68", 50)
    assert (other.name, other.n_points, other.edges) == ("ibug68", 50, ())
    imm = resolve_scheme("imm73", 73)
    assert (imm.n_points, imm.edges) == (73, ())


def test_keypoint_labels_name_the_coarse_group_of_each_point():
    labels = keypoint_labels(IBUG68)
    assert len(labels) == 68
    for group in ("jaw", "brows", "nose", "eyes", "mouth"):
        for i in IBUG68.groups[group]:
            assert labels[i] == f"{group} {i}"
    assert keypoint_labels(resolve_scheme("x", 3)) == ["point 0", "point 1", "point 2"]


def test_class_description_connects_the_scheme_edges():
    desc = class_description(IBUG68, 4, "ibug68", (1, 2, 3))
    assert desc.info.id == 4 and str(desc.info.label) == "ibug68"
    pairs = [(c.keypoint0.id, c.keypoint1.id) for c in desc.keypoint_connections]
    assert pairs == list(IBUG68.edges)
    assert [a.id for a in desc.keypoint_annotations] == list(range(68))
    assert str(desc.keypoint_annotations[48].label) == "mouth 48"


def test_landmark_classes_give_two_classes_per_scheme_in_order_of_use():
    classes = LandmarkClasses()
    assert classes.class_id("ibug68", 68) == (0, True)
    assert classes.class_id("ibug68", 68, failed=True) == (1, False)
    assert classes.class_id("imm73", 73, failed=True) == (3, True)
    assert classes.class_id("imm73", 73) == (2, False)
    assert classes.class_id("ibug68", 68) == (0, False)
    (classes_logged,) = classes.context().context.as_arrow_array().to_pylist()
    assert [c["class_id"] for c in classes_logged] == [0, 1, 2, 3]
    labels = [c["class_description"]["info"]["label"] for c in classes_logged]
    assert labels == ["ibug68 (68 points)", "ibug68 (68 points), failed",
                      "imm73 (73 points)", "imm73 (73 points), failed"]
