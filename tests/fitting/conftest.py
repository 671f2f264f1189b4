from pathlib import Path

import pytest

from aamcore.fitting.fitter import prepare_fitting
from aamcore.model.file import load_model, save_model
from aamcore.model.training import TrainConfig, train_aam


@pytest.fixture(scope="session")
def imm_train(imm_set):
    return [s for s in imm_set.samples if int(s.subject) <= 9]


@pytest.fixture(scope="session")
def imm_test(imm_set):
    return [s for s in imm_set.samples if int(s.subject) > 9]


@pytest.fixture(scope="session")
def imm_fit_model_path(imm_set, imm_train, tmp_path_factory) -> Path:
    """A grey IMM model with everything fitting needs, trained on subjects 01-09."""
    aam = train_aam(
        imm_train, imm_set.scheme, TrainConfig(n_pixels=6000, colour=False, shape_variance=0.98)
    )
    aam = prepare_fitting(aam, imm_train, max_images=25)
    return save_model(aam, tmp_path_factory.mktemp("fit") / "imm_fit.npz")


@pytest.fixture(scope="session")
def imm_fit_model(imm_fit_model_path):
    return load_model(imm_fit_model_path)
