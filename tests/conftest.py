"""Shared fixtures: the data root and paths to the real datasets."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import pytest

from aamcore.config import data_root
from aamcore.fitting.model import FittingModel
from aamcore.fitting.training.prepare import train_fitting_model
from aamcore.io.jaffe import JaffeSet, load_jaffe
from aamcore.model.training import TrainConfig, train_aam

MODEL_LIMIT = 300
"""Training faces of the small test model: the first 100 of each training split of LFPW,
HELEN and AFW (cached after the first run, about 30 s). With 120 faces its tracking
drifted on ``single_face.mp4`` (jaw off the head model from frame 45 on)."""
MODEL_IMAGES = 10
CLASSIFIER_LIMIT = 10
"""Faces of each class of the Taiwanese and LFW sets the tests' classifier learns from
(with all of JAFFE): 344 faces, the whole recipe in a few seconds."""


@pytest.fixture(scope="session")
def data_dir() -> Path:
    root = data_root()
    if not root.is_dir():
        pytest.fail(f"data root {root} not found: set AAMTRACK_DATA")
    return root


@pytest.fixture(scope="session")
def imm_dir(data_dir: Path) -> Path:
    return data_dir / "imm_frontal"


@pytest.fixture(scope="session")
def lfpw_dir(data_dir: Path) -> Path:
    return data_dir / "lfpw" / "trainset"


@pytest.fixture(scope="session")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A model cache for this test session, outside the repository."""
    import os

    path = tmp_path_factory.mktemp("aamtrack-cache")
    os.environ["AAMTRACK_CACHE"] = str(path)
    return path


@pytest.fixture(scope="session")
def imm_set(imm_dir: Path):
    from aamcore.io import load_annotated_folder

    return load_annotated_folder(imm_dir)


@pytest.fixture(scope="session")
def imm_model(imm_set):
    """A small colour AAM trained on IMM subjects 01-09 (10-12 held out)."""
    from aamcore.model.training import TrainConfig, train_aam

    train = [s for s in imm_set.samples if int(s.subject) <= 9]
    return train_aam(train, imm_set.scheme, TrainConfig(n_pixels=4000))


@pytest.fixture(scope="session")
def lfpw_fit_model_path(model_path: Path) -> Path:
    """A small 68-point model ready for fitting: the small test model."""
    return model_path


@pytest.fixture(scope="session")
def model_path() -> Path:
    """The small 68-point model ready for fitting, from the user cache (trained on first
    use): the default recipe on :data:`MODEL_LIMIT` faces."""
    from aamcore.fitting.training.prepare import default_model_path

    return default_model_path(max_images=MODEL_IMAGES, limit=MODEL_LIMIT)


@pytest.fixture(scope="session")
def classifier_path(model_path: Path) -> Path:
    """The expression classifier for :func:`model_path`, learned from JAFFE and
    :data:`CLASSIFIER_LIMIT` faces of each class of the other two sets (trained on first
    use)."""
    from aamcore.expression.training import classifier_path as cached

    return cached(model_path, limit=CLASSIFIER_LIMIT)


@pytest.fixture(scope="session")
def jaffe_dir(data_dir: Path) -> Path:
    return data_dir / "jaffe"


@pytest.fixture(scope="session")
def jaffe_set(jaffe_dir: Path) -> JaffeSet:
    return load_jaffe(jaffe_dir)


@pytest.fixture(scope="session")
def jaffe(model_path: Path, jaffe_dir: Path):
    """Every JAFFE face (213) fitted by the small test model as the stack fits a frame
    (``LabelledFaces``, images kept)."""
    from aamcore.expression.faces import fit_faces
    from aamcore.io.expression_sets import load_expression_set

    return fit_faces(FittingModel.load(model_path), load_expression_set("jaffe", jaffe_dir),
                     keep_images=True)


@pytest.fixture(scope="session")
def imm_train(imm_set):
    return [s for s in imm_set.samples if int(s.subject) <= 9]


@pytest.fixture(scope="session")
def imm_test(imm_set):
    return [s for s in imm_set.samples if int(s.subject) > 9]


@pytest.fixture(scope="session")
def imm_fit_model_path(imm_dir: Path, imm_set, imm_train) -> Path:
    """A grey IMM model with everything fitting needs, trained on subjects 01-09; kept in the
    user cache as the recipe's models are (trained once for every test session and worker
    that wants it, again when the recipe changes)."""
    from aamcore.config import cache_dir
    from aamcore.fitting.training.prepare import BINARY, OCCLUSION, RECIPE
    from aamcore.model.cache import cache_key, cached_file

    config = TrainConfig(n_pixels=6000, colour=False, shape_variance=0.98)
    key = cache_key(str(imm_dir), config, {"select": "subjects 01-09", "max_images": 25,
                                           "prepare": RECIPE, "binary": BINARY.to_json(),
                                           "occlusion": asdict(OCCLUSION)})

    def build(path: Path) -> Path:
        aam = train_aam(imm_train, imm_set.scheme, config)
        return train_fitting_model(aam, imm_train, max_images=25).save(path)

    return cached_file(cache_dir() / f"imm-tests-{key}.npz", build, FittingModel.load)


@pytest.fixture(scope="session")
def imm_fit_model(imm_fit_model_path):
    return FittingModel.load(imm_fit_model_path)


@pytest.fixture(scope="session")
def videos(data_dir: Path) -> Path:
    return data_dir / "videos"


@pytest.fixture(scope="session")
def single_face(videos: Path) -> Path:
    return videos / "single_face.mp4"


@pytest.fixture(scope="session")
def no_face(videos: Path) -> Path:
    return videos / "no_face.mp4"
