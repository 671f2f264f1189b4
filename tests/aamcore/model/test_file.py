import json
import zipfile

import numpy as np
import pytest

from aamcore.model.file import FORMAT_VERSION, ModelFileError, load_model, save_model
from aamcore.model.similarity import Similarity


def test_round_trip_is_exact(imm_model, tmp_path) -> None:
    path = save_model(imm_model, tmp_path / "m")
    loaded = load_model(path)
    for a, b in (
        (imm_model.shape.pca, loaded.shape.pca),
        (imm_model.texture.pca, loaded.texture.pca),
        (imm_model.combined.pca, loaded.combined.pca),
    ):
        np.testing.assert_array_equal(a.components, b.components)
        np.testing.assert_array_equal(a.variances, b.variances)
        np.testing.assert_array_equal(a.mean, b.mean)
    np.testing.assert_array_equal(loaded.frame.pixels, imm_model.frame.pixels)
    np.testing.assert_array_equal(loaded.frame.triangles, imm_model.frame.triangles)
    assert loaded.scheme == imm_model.scheme
    c = np.linspace(-1, 1, imm_model.n_appearance)
    sim = Similarity.from_params(np.array([0.1, 0.05, 300.0, 200.0]))
    np.testing.assert_array_equal(loaded.shape_instance(c, sim), imm_model.shape_instance(c, sim))
    np.testing.assert_array_equal(loaded.texture_instance(c), imm_model.texture_instance(c))


def _rewrite_header(src, dst, change) -> None:
    with np.load(src, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    header = json.loads(arrays["header"].tobytes())
    change(header)
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), np.uint8)
    np.savez(dst, **arrays)


def test_other_version_is_refused(imm_model, tmp_path) -> None:
    path = save_model(imm_model, tmp_path / "m.npz")
    old = tmp_path / "old.npz"
    _rewrite_header(path, old, lambda h: h.update(format_version=FORMAT_VERSION + 7))
    with pytest.raises(
        ModelFileError, match=f"version {FORMAT_VERSION + 7}.*version {FORMAT_VERSION}"
    ):
        load_model(old)


def test_corrupt_and_foreign_files(imm_model, tmp_path) -> None:
    path = save_model(imm_model, tmp_path / "m.npz")
    cut = tmp_path / "cut.npz"
    cut.write_bytes(path.read_bytes()[:5000])
    with pytest.raises(ModelFileError, match="cut.npz"):
        load_model(cut)
    with pytest.raises(ModelFileError, match="not found"):
        load_model(tmp_path / "none.npz")
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, header=np.array([object()], dtype=object))
    with pytest.raises(ModelFileError):
        load_model(foreign)
    plain = tmp_path / "plain.npz"
    np.savez(plain, x=np.zeros(3))
    with pytest.raises(ModelFileError, match="no header"):
        load_model(plain)
    assert zipfile.is_zipfile(path)
