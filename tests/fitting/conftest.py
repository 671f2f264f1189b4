from pathlib import Path

import pytest

from aamcore.fitting.model import FittingModel
from aamcore.fitting.training.prepare import train_fitting_model
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
    model = train_fitting_model(aam, imm_train, max_images=25)
    return model.save(tmp_path_factory.mktemp("fit") / "imm_fit.npz")


@pytest.fixture(scope="session")
def imm_fit_model(imm_fit_model_path):
    return FittingModel.load(imm_fit_model_path)
