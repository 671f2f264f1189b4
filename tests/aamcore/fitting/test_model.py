"""aamcore.fitting.model: the local-binary cascade in the model file, old files refused."""

from __future__ import annotations

import json
import zipfile

import numpy as np
import pytest

from aamcore.fitting.algorithm import make_algorithm
from aamcore.fitting.algorithm.base import AlgorithmSettings
from aamcore.fitting.model import FittingModel
from aamcore.model.file import ModelFileError


@pytest.fixture(scope="module")
def saved(synthetic_aam, synthetic_mapping, synthetic_binary, tmp_path_factory):
    model = FittingModel(synthetic_aam, synthetic_mapping, [], None, synthetic_binary)
    return model.save(tmp_path_factory.mktemp("model") / "synthetic.npz")


def test_the_cascade_round_trips(saved, synthetic_binary) -> None:
    loaded = FittingModel.load(saved)
    binary = loaded.binary
    assert binary is not None and binary.threshold == synthetic_binary.threshold
    assert np.array_equal(binary.space.basis, synthetic_binary.space.basis)
    for a, b in zip(binary.tracking, synthetic_binary.tracking, strict=True):
        assert np.array_equal(a.offsets, b.offsets) and np.array_equal(a.weights, b.weights)
    for a, b in zip(binary.coarse, synthetic_binary.coarse, strict=True):
        assert np.array_equal(a.weights, b.weights) and a.window == b.window
    assert binary.report["faces"] == synthetic_binary.report["faces"]
    assert make_algorithm("local-binary", loaded, AlgorithmSettings()).name == "local-binary"
    with np.load(saved, allow_pickle=False) as data:  # plain arrays, no pickled object
        assert all(data[k].dtype != object for k in data.files)


def test_a_model_without_the_cascade_is_refused_for_the_method(
        synthetic_aam, synthetic_mapping, tmp_path) -> None:
    path = FittingModel(synthetic_aam, synthetic_mapping, []).save(tmp_path / "plain.npz")
    model = FittingModel.load(path)
    assert model.binary is None
    with pytest.raises(ValueError, match="no local-binary cascade"):
        make_algorithm("local-binary", model, AlgorithmSettings())


def _rewrite(path, target, change) -> None:
    with np.load(path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    header = json.loads(arrays["header"].tobytes().decode())
    change(header)
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), np.uint8)
    np.savez(target, **arrays)


def test_older_model_files_are_refused_clearly(saved, tmp_path) -> None:
    old = tmp_path / "old.npz"
    _rewrite(saved, old, lambda h: h.update(format_version=2))
    with pytest.raises(ModelFileError, match="version 2, this aamtrack reads version 3"):
        FittingModel.load(old)
    broken = tmp_path / "broken.npz"
    _rewrite(saved, broken, lambda h: h["extra"]["binary"].update(tracking=5))
    with pytest.raises(ModelFileError, match="incomplete fitting part"):
        FittingModel.load(broken)
    assert zipfile.is_zipfile(saved)


def test_every_part_round_trips_and_a_missing_one_is_named(
        synthetic_aam, synthetic_mapping, synthetic_binary, synthetic_faces, tmp_path) -> None:
    from aamcore.fitting.algorithm import missing_part
    from aamcore.fitting.training.occlusion import OcclusionTrainConfig, train_occlusion

    occlusion = train_occlusion(synthetic_aam, synthetic_faces.train, None,
                                OcclusionTrainConfig(faces=8, occluded=1, epochs=20))
    model = FittingModel(synthetic_aam, synthetic_mapping, [], None, synthetic_binary, occlusion)
    loaded = FittingModel.load(model.save(tmp_path / "parts.npz"))
    assert loaded.occlusion is not None and loaded.occlusion.threshold == occlusion.threshold
    assert np.array_equal(loaded.occlusion.centre, occlusion.centre)
    assert loaded.update_method == "" and missing_part(loaded, "local-binary") == ""
    assert "no update matrix, which fixed-jacobian needs" in missing_part(loaded, "fixed-jacobian")
    assert "supervised-descent cascade" in missing_part(loaded, "supervised-descent")
    assert missing_part(loaded, "project-out-ic") == ""
    assert "unknown fitting algorithm" in missing_part(loaded, "newton")


def test_reading_a_model_imports_no_fitting_algorithm() -> None:
    import subprocess
    import sys

    code = ("import sys, aamcore.fitting.model; "
            "print(sorted(m for m in sys.modules if m.startswith('aamcore.fitting.algorithm.')"
            " and m.rsplit('.', 1)[1] in ('local_binary', 'supervised_descent', "
            "'fixed_jacobian', 'multi_resolution', 'project_out_ic')))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=60, check=True)
    assert done.stdout.strip() == "[]"
