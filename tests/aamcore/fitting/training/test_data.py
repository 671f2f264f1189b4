"""aamcore.fitting.training.data: the training faces of several sets, read and detected."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.fitting.training.data import (
    dataset_names,
    detect_faces,
    no_face_frames,
    training_set,
)
from aamcore.io.splits import is_held_out


def test_names_and_the_training_split_only(data_dir) -> None:
    assert dataset_names(" lfpw, helen ,afw") == ["lfpw", "helen", "afw"]
    with pytest.raises(ValueError, match="no dataset"):
        dataset_names(" , ")
    data = training_set("lfpw,helen,afw", limit=9)
    assert len(data.samples) == 9 and data.split == [True, True, True]
    assert data.name == "lfpw-helen-afw" and data.scheme.name == "ibug68"
    for sample in data.samples:
        set_name = next(n for n in ("lfpw", "helen", "afw") if n in str(sample.image_path))
        assert not is_held_out(sample.image_path.stem, set_name)
    whole = training_set([str(data_dir / "imm_frontal")])
    assert whole.split == [False] and len(whole.samples) == 120
    with pytest.raises(ValueError, match="one markup"):
        training_set("lfpw,imm_frontal", limit=4)


def test_faces_are_read_once_detected_and_shrunk(data_dir) -> None:
    samples = training_set("lfpw", limit=4).samples
    found = detect_faces(samples, n_jobs=2, max_face_width=100.0)
    assert len(found) == 4
    for face, sample in zip(found, samples, strict=True):
        assert face.grey.ndim == 2 and face.factor <= 1.0
        assert np.ptp(sample.points[:, 0]) * face.factor <= 100.5
        assert face.box is None or any(np.array_equal(face.box, b) for b in face.boxes)
    assert sum(f.box is not None for f in found) >= 3
    frames = no_face_frames()
    assert len(frames) == 47 and frames[0].ndim == 2  # the first half of the 95 it reads
    assert no_face_frames(data_dir / "missing.mp4") == []
