"""aamcore.fitting.training.prepare: the default model's recipe, on the small test model."""

from __future__ import annotations

from aamcore.fitting.model import FittingModel
from aamcore.fitting.training.prepare import subset


def test_subset_spreads_over_the_samples() -> None:
    assert subset(list(range(10)), 4) == [0, 2, 5, 7]
    assert subset(list(range(3)), 10) == [0, 1, 2] and subset(list(range(3)), None) == [0, 1, 2]


def test_small_default_model_has_every_part(model_path) -> None:
    model = FittingModel.load(model_path)
    assert model_path.name.startswith("lfpw-helen-afw-")
    assert model.binary is not None and model.cascade is not None and len(model.updates) == 2
    report = model.binary.report
    assert report["faces"] == 600  # 300 faces of the three training splits and their mirrors
    assert report["no_face_frames"] > 0 and model.binary.space.n_points == 68
    assert len(model.aam.summary["fit_images"]) == 300


def test_models_without_a_mirror_permutation_train_without_one(imm_fit_model) -> None:
    binary = imm_fit_model.binary
    assert binary is not None and binary.report["faces"] == len(imm_fit_model.aam.summary[
        "fit_images"]) == 90
    assert binary.space.eye_corners == imm_fit_model.aam.scheme.eye_corners
