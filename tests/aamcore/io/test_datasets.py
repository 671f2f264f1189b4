from pathlib import Path

import numpy as np
import pytest

from aamcore.config import resolve_dataset
from aamcore.io import DatasetError, load_annotated_folder, read_asf, read_pts


def test_imm_folder(imm_set) -> None:
    assert len(imm_set.samples) == 120
    assert imm_set.scheme.name == "imm73"
    assert imm_set.subjects() == [f"{i:02d}" for i in range(1, 13)]
    first = imm_set.samples[0]
    assert first.points.shape == (73, 2)
    image = first.load_image()
    assert image.shape == (600, 800, 3)
    # Landmarks lie on the face, well inside the image.
    assert np.all(first.points > 50) and np.all(first.points < [750, 550])
    assert set(imm_set.scheme.groups) >= {"eyes", "brows", "nose", "mouth", "jaw"}


def test_imm_outer_eye_corners(imm_set) -> None:
    pts = imm_set.samples[0].points
    left, right = imm_set.scheme.eye_corners
    eyes = list(imm_set.scheme.groups["eyes"])
    assert pts[left, 0] == pytest.approx(pts[eyes, 0].min())
    assert pts[right, 0] == pytest.approx(pts[eyes, 0].max())


def test_lfpw_pts_are_zero_based(lfpw_dir: Path) -> None:
    raw = [ln.split() for ln in (lfpw_dir / "image_0001.pts").read_text().splitlines()[3:71]]
    points = read_pts(lfpw_dir / "image_0001.pts")
    assert points.shape == (68, 2)
    np.testing.assert_allclose(points, np.array(raw, float) - 1.0)


def test_lfpw_folder_limit(lfpw_dir: Path) -> None:
    data = load_annotated_folder(lfpw_dir, limit=20)
    assert len(data.samples) == 20 and data.scheme.name == "ibug68"
    assert data.samples[0].subject is None


def test_resolve_names() -> None:
    assert resolve_dataset("lfpw").name == "trainset"
    with pytest.raises(FileNotFoundError, match="AAMTRACK_DATA"):
        resolve_dataset("no_such_set")


def _write_pts(path: Path, points: np.ndarray, declared: int | None = None) -> None:
    n = len(points) if declared is None else declared
    lines = ["version: 1", f"n_points: {n}", "{"] + [f"{x} {y}" for x, y in points] + ["}"]
    path.write_text("\n".join(lines))


def test_bad_files_are_named_and_skipped(tmp_path: Path, lfpw_dir: Path) -> None:
    good = load_annotated_folder(lfpw_dir, limit=3).samples
    for k, s in enumerate(good):
        (tmp_path / f"good{k}.jpg").write_bytes(s.image_path.read_bytes())
        _write_pts(tmp_path / f"good{k}.pts", s.points + 1)
    (tmp_path / "truncated.pts").write_text("version: 1\nn_points: 68\n{\n1 2\n")
    (tmp_path / "truncated.jpg").write_bytes(good[0].image_path.read_bytes())
    _write_pts(tmp_path / "noimage.pts", good[0].points)
    _write_pts(tmp_path / "fewer.pts", good[0].points[:60])
    (tmp_path / "fewer.jpg").write_bytes(good[0].image_path.read_bytes())
    _write_pts(tmp_path / "liar.pts", good[0].points, declared=70)
    (tmp_path / "liar.jpg").write_bytes(good[0].image_path.read_bytes())
    (tmp_path / "unannotated.png").write_bytes(good[0].image_path.read_bytes())
    data = load_annotated_folder(tmp_path)
    assert len(data.samples) == 3
    messages = "\n".join(data.errors)
    assert len(data.errors) == 5
    assert "unannotated.png" in messages and "no .pts or .asf" in messages
    assert "truncated.pts" in messages and "closing" in messages
    assert "noimage.pts" in messages and "no image" in messages
    assert "fewer.jpg" in messages and "60 points" in messages
    assert "liar.pts" in messages and "header says 70" in messages


def test_bad_asf(tmp_path: Path, imm_dir: Path) -> None:
    text = (imm_dir / "01_01.asf").read_text()
    cut = tmp_path / "cut.asf"
    cut.write_text(text[: len(text) // 2])
    with pytest.raises(DatasetError, match="cut.asf.*truncated"):
        read_asf(cut)
    garbage = tmp_path / "garbage.asf"
    garbage.write_text("hello\n")
    with pytest.raises(DatasetError, match="garbage.asf"):
        read_asf(garbage)
    with pytest.raises(DatasetError, match="missing.asf"):
        read_asf(tmp_path / "missing.asf")


def test_empty_folder(tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match="no .asf or .pts"):
        load_annotated_folder(tmp_path)
    with pytest.raises(DatasetError, match="not found"):
        load_annotated_folder(tmp_path / "nope")
