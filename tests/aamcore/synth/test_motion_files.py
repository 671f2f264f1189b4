"""Motion sequences written to disk read back frame for frame, with their ground truth."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from aamcore.io.video import video_frames
from aamcore.synth.motion import MotionSpec, Sequence, generate
from aamcore.synth.motion_files import read_ground_truth, video_path, write_sequence


def photo_and_points() -> tuple[np.ndarray, np.ndarray]:
    """A textured (300, 300, 3) photo and 68 points (68, 2) spread over its middle."""
    rng = np.random.default_rng(7)
    photo = cv2.GaussianBlur(rng.integers(0, 256, (300, 300, 3), dtype=np.uint8), (0, 0), 2)
    points = rng.uniform(80.0, 220.0, (68, 2))
    return photo, points


def sequence(spec: MotionSpec) -> Sequence:
    photo, points = photo_and_points()
    return generate(photo, points, spec)


def test_written_sequence_reads_back_exactly(tmp_path: Path) -> None:
    spec = MotionSpec(frames=8, occluder=(2, 6), seed=3)
    seq = sequence(spec)
    files = write_sequence(seq, tmp_path / "seq", fps=25.0, spec=spec)
    assert files.video == video_path(tmp_path / "seq") and files.video.suffix == ".avi"
    frames = video_frames(files.video)
    assert len(frames) == 8
    for written, read in zip(seq.frames, frames, strict=True):
        np.testing.assert_array_equal(written, read)  # lossless
    truth = read_ground_truth(tmp_path / "seq")
    np.testing.assert_array_equal(truth.landmarks, seq.landmarks)
    np.testing.assert_array_equal(truth.occluded, seq.occluded)
    np.testing.assert_array_equal(truth.covered, seq.covered)
    assert truth.occluded.any() and truth.frames == 8
    # the landmarks the hand covers are in frames with the hand, and only there
    assert truth.covered.shape == (8, 68) and np.all((truth.covered >= 0) & (truth.covered <= 1))
    assert truth.covered[truth.occluded].max() > 0.5 and not truth.covered[~truth.occluded].any()
    assert truth.fps == 25.0 and truth.spec == spec


def test_sequence_write_keeps_no_spec_and_a_rewrite_replaces(tmp_path: Path) -> None:
    first = sequence(MotionSpec(frames=5, seed=1))
    assert write_sequence(first, tmp_path).video == tmp_path / "video.avi"
    truth = read_ground_truth(tmp_path)
    assert truth.spec is None and truth.fps == 30.0 and not truth.occluded.any()
    second = sequence(MotionSpec(frames=3, seed=2))
    write_sequence(second, tmp_path)
    assert len(video_frames(tmp_path / "video.avi")) == 3
    np.testing.assert_array_equal(read_ground_truth(tmp_path).landmarks, second.landmarks)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["truth.npz", "video.avi"]


def test_a_folder_without_a_sequence_has_no_ground_truth(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        read_ground_truth(tmp_path)


def test_covered_shares_are_the_share_of_each_landmarks_disc() -> None:
    from aamcore.synth.motion import PART_RADIUS, covered_shares

    mask = np.zeros((100, 200), np.uint8)
    mask[:, :100] = 255  # the left half covered
    points = np.array([[20.0, 50.0], [180.0, 50.0], [100.0, 50.0], [0.0, 0.0]])
    shares = covered_shares(mask, points)
    assert shares[0] == 1.0 and shares[1] == 0.0 and 0.4 < shares[2] < 0.6
    assert shares[3] == 1.0  # a disc partly outside the frame counts its inside
    assert PART_RADIUS * 180 > 10  # the discs above are about 14 px
