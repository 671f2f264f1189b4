import shutil

import numpy as np
import pytest

from aamcore.io import load_annotated_folder
from aamcore.model.texture import normalise_texture
from aamcore.model.training import TrainConfig, TrainingError, train_aam


def _texture_error(aam, sample) -> float:
    image = sample.load_image()
    c, t = aam.parameters_of(image, sample.points)
    g = aam.sample(aam.prepare_image(image, sample.points), sample.points)
    return float(np.mean((aam.texture_instance(c) - g) ** 2))


def test_models_are_consistent(imm_model) -> None:
    aam = imm_model
    assert aam.shape.n_modes >= 3 and aam.texture.n_modes >= 5
    assert aam.n_appearance <= aam.shape.n_modes + aam.texture.n_modes
    # c = 0 is the mean face.
    np.testing.assert_allclose(aam.model_shape(np.zeros(aam.n_appearance)), aam.shape.mean_shape)
    np.testing.assert_allclose(aam.texture_instance(np.zeros(aam.n_appearance)), aam.texture.mean)
    assert abs(aam.frame.n_pixels - 4000) < 200


def test_appearance_round_trip(imm_model, imm_set) -> None:
    sample = imm_set.samples[3]
    c, t = imm_model.parameters_of(sample.load_image(), sample.points)
    shape = imm_model.shape_instance(c, t)
    iod = imm_set.scheme.inter_ocular(sample.points)
    # The combined model keeps 95 % of the variance: shape comes back closely.
    assert np.mean(np.linalg.norm(shape - sample.points, axis=1)) < 0.05 * iod


def test_training_images_reconstruct_better_than_held_out(imm_model, imm_set) -> None:
    train = [s for s in imm_set.samples if int(s.subject) <= 9][::6]
    test = [s for s in imm_set.samples if int(s.subject) > 9][::2]
    e_train = np.mean([_texture_error(imm_model, s) for s in train])
    e_test = np.mean([_texture_error(imm_model, s) for s in test])
    assert e_train < e_test


def test_normalisation() -> None:
    g = np.random.default_rng(0).uniform(0, 255, 1000)
    n, alpha, beta = normalise_texture(g)
    assert abs(n.mean()) < 1e-9 and abs(np.linalg.norm(n) - np.sqrt(1000)) < 1e-6
    np.testing.assert_allclose(n * alpha + beta, g)


def test_training_refuses_too_few_or_inconsistent(imm_set) -> None:
    with pytest.raises(TrainingError, match="at least 3"):
        train_aam(imm_set.samples[:2], imm_set.scheme)
    with pytest.raises(TrainingError, match="all .* modes"):
        train_aam(
            imm_set.samples[:5], imm_set.scheme, TrainConfig(texture_variance=0.999, n_pixels=2000)
        )


def test_training_skips_unreadable_images(imm_set, tmp_path) -> None:
    from dataclasses import replace

    samples = imm_set.samples[:12]
    broken = tmp_path / "broken.jpg"
    broken.write_bytes(b"not a jpeg")
    samples = [replace(samples[0], image_path=broken)] + samples[1:]
    aam = train_aam(
        samples,
        imm_set.scheme,
        TrainConfig(n_pixels=2000, texture_variance=0.8, shape_variance=0.8, combined_variance=0.8),
    )
    assert aam.summary["images"] == 11
    assert any("broken.jpg" in s for s in aam.summary["skipped"])


def test_skipped_image_leaves_frame_and_textures_consistent(imm_dir, tmp_path) -> None:
    # An image that breaks after loading: the frame and the textures must both
    # come from the 11 readable images (texture length == frame pixels x channels).
    for jpg in sorted(imm_dir.glob("*.jpg"))[:12]:
        shutil.copyfile(jpg, tmp_path / jpg.name)
        shutil.copyfile(jpg.with_suffix(".asf"), tmp_path / jpg.with_suffix(".asf").name)
    data = load_annotated_folder(tmp_path)
    assert len(data.samples) == 12
    data.samples[0].image_path.write_bytes(b"not a jpeg")
    config = TrainConfig(
        n_pixels=2000, texture_variance=0.8, shape_variance=0.8, combined_variance=0.8
    )
    aam = train_aam(data.samples, data.scheme, config)
    assert aam.summary["images"] == 11 and len(aam.summary["skipped"]) == 1
    assert aam.texture.mean.size == aam.frame.n_pixels * aam.channels
    assert aam.texture_basis.shape[0] == aam.frame.n_pixels * aam.channels
    # The same model as one trained on the readable images alone.
    clean = train_aam(data.samples[1:], data.scheme, config)
    assert aam.frame.n_pixels == clean.frame.n_pixels
    np.testing.assert_array_equal(aam.shape.mean_shape, clean.shape.mean_shape)
    np.testing.assert_array_equal(aam.texture.mean, clean.texture.mean)
    c, t = aam.parameters_of(data.samples[1].load_image(), data.samples[1].points)
    assert aam.texture_instance(c).shape == aam.texture.mean.shape
