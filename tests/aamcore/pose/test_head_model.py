"""3D head models: OpenFace mean68, CSV models, the derived IMM-73 model, subsets."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aamcore.io import load_annotated_folder
from aamcore.pose.errors import PoseError
from aamcore.pose.head_model import (
    IBUG68_SUBSETS,
    IMM73_SUBSETS,
    RECOMMENDED_SUBSET,
    imm73,
    load_csv_model,
    openface68,
)
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.posit import flatness


def test_openface68_axes_and_origin() -> None:
    m = openface68()
    assert m.points.shape == (68, 3) and m.scheme == "ibug68"
    assert np.allclose(m.points.mean(axis=0), 0.0, atol=1e-6)
    assert m.points[30, 2] < m.points[36, 2] - 20  # nose tip nearer the camera than the eyes
    assert m.points[36, 0] < 0 < m.points[45, 0]  # subject's right eye on image left
    assert m.points[8, 1] > m.points[27, 1]  # chin below the nose bridge (+y down)
    assert 120 < np.ptp(m.points[:, 0]) < 170  # a head about 14 cm wide, in mm


def test_subsets() -> None:
    m = openface68()
    rigid = openface68(rigid_subset=True)
    assert rigid.name.endswith(f"[{RECOMMENDED_SUBSET['ibug68']}]")
    assert set(rigid.indices.tolist()) == set(IBUG68_SUBSETS[RECOMMENDED_SUBSET["ibug68"]])
    assert np.allclose(rigid.points, m.points[rigid.indices])  # same origin as the full model
    landmarks = np.arange(136.0).reshape(68, 2)
    assert np.array_equal(rigid.select(landmarks), landmarks[rigid.indices])
    assert rigid.indices.tolist() == list(range(60))  # the inner lips are left out
    no_jaw = m.subset("no_jaw")
    assert no_jaw.indices.min() == 17 and len(no_jaw.indices) == 51
    assert len(m.subset([30, 36, 45, 48, 54, 8]).indices) == 6
    with pytest.raises(PoseError, match="no subset 'nope'"):
        m.subset("nope")
    with pytest.raises(PoseError, match="no point for landmarks"):
        no_jaw.subset([0, 1, 2, 30])
    with pytest.raises(PoseError, match="expects 68 landmarks"):
        rigid.select(np.zeros((73, 2)))
    for name in IBUG68_SUBSETS:
        assert flatness(m.subset(name).points) > 0.1  # POSIT can use every subset


def test_csv_models(tmp_path: Path) -> None:
    three = tmp_path / "three.csv"
    three.write_text("# x,y,z\nx,y,z\n0,0,0\n10,0,5\n0,10,5\n10,10,0\n5,5,-8\n")
    m = load_csv_model(three, "custom")
    assert m.n_landmarks == 5 and np.allclose(m.points.mean(axis=0), 0.0)
    four = tmp_path / "four.csv"
    four.write_text("3,0,0,0\n7,1,0,0.5\n9,0,1,0.5\n12,1,1,0\n")
    m = load_csv_model(four, "custom", n_landmarks=20, mm_per_unit=10.0)
    assert m.indices.tolist() == [3, 7, 9, 12] and m.n_landmarks == 20
    assert np.ptp(m.points[:, 0]) == pytest.approx(10.0)
    bad = tmp_path / "bad.csv"
    bad.write_text("0,0,0\n1,0,0\n0,1,0\nzero,1,1\n")
    with pytest.raises(PoseError, match=r"bad\.csv:4: not numeric"):
        load_csv_model(bad, "custom")
    mixed = tmp_path / "mixed.csv"
    mixed.write_text("0,0,0\n1,0,0,4\n")
    with pytest.raises(PoseError, match="rows of 3"):
        load_csv_model(mixed, "custom")
    dup = tmp_path / "dup.csv"
    dup.write_text("1,0,0,0\n1,1,0,0\n2,0,1,0\n3,0,0,1\n")
    with pytest.raises(PoseError, match="distinct"):
        load_csv_model(dup, "custom")
    few = tmp_path / "few.csv"
    few.write_text("0,0,0\n1,0,0\n0,1,0\n")
    with pytest.raises(PoseError, match="at least 4"):
        load_csv_model(few, "custom")
    with pytest.raises(PoseError, match="not found"):
        load_csv_model(tmp_path / "none.csv", "custom")


def test_imm73_model_is_a_plausible_head() -> None:
    m = imm73()
    of = openface68().points
    p = m.points
    assert p.shape == (73, 3) and m.scheme == "imm73" and np.all(np.isfinite(p))
    assert "outside the mesh" not in m.source  # every point found its depth on the mesh
    assert p[45, 2] == pytest.approx(of[30, 2], abs=5.0)  # nose tip depth as OpenFace's
    assert p[45, 2] < p[[16, 24], 2].min() - 25  # nose tip in front of the eye corners
    assert p[[62, 72], 2].min() > p[[16, 24], 2].max() + 30  # jaw ends far behind the eyes
    # Left-right symmetric: mirrored pairs (outer eye corners, mouth corners, jaw ends).
    for a, b in [(16, 24), (46, 52), (62, 72), (32, 33)]:
        assert p[a, 0] == pytest.approx(-p[b, 0], abs=4.0)
        assert p[a, 2] == pytest.approx(p[b, 2], abs=4.0)
    for name in IMM73_SUBSETS:
        assert flatness(m.subset(name).points) > 0.1
    rigid = imm73(rigid_subset=True)
    assert set(rigid.indices.tolist()) == set(IMM73_SUBSETS[RECOMMENDED_SUBSET["imm73"]])


def test_imm73_gives_frontal_poses_on_imm_annotations(imm_dir: Path) -> None:
    """The IMM Frontal faces look at the camera: small roll and yaw, plausible distance."""
    samples = load_annotated_folder(imm_dir).samples[::4]
    model = imm73()
    posit = model.posit()
    cam = CameraIntrinsics.from_fov(800, 600, 50.0)  # field of view assumed
    for s in samples:
        est = posit.estimate(model.select(s.points), cam)
        assert est.reliable, (s.image_path.name, est.reason)
        assert abs(est.rpy.roll) < 10 and abs(est.rpy.yaw) < 12 and abs(est.rpy.pitch) < 25
        assert 350 < est.distance < 800  # mm


def test_openface68_fits_lfpw_annotations(lfpw_dir: Path) -> None:
    samples = load_annotated_folder(lfpw_dir, limit=40).samples
    posit = openface68().posit()
    for s in samples:
        size = int(max(s.points.max(axis=0)) * 1.2)
        est = posit.estimate(s.points, CameraIntrinsics.from_fov(size, size, 50.0))
        assert est.reliable, (s.image_path.name, est.reason)


def test_head_models_by_name() -> None:
    from aamcore.pose.head_model import head_model_named

    assert head_model_named("openface68").n_landmarks == 68
    assert head_model_named("exact", head_model_named("imm73")).name.startswith("imm73")
    with pytest.raises(ValueError, match="unknown model 'exact'"):
        head_model_named("exact")
