"""aamcore.fitting.residuals: the texture residual of a model instance on synthetic faces."""

from __future__ import annotations

import numpy as np

from aamcore.fitting.residuals import ResidualFunction
from aamcore.model.similarity import Similarity


def test_the_residual_is_smallest_at_the_true_parameters(synthetic_aam, synthetic_faces) -> None:
    aam = synthetic_aam
    residual = ResidualFunction(aam)
    sample = synthetic_faces.train[3]
    image = aam.prepare_image(sample.load_image())
    c, sim = aam.parameters_of(sample.load_image(), sample.points)
    r, error = residual(image, c, sim.params)
    assert r.shape == (aam.frame.n_pixels,) and r.dtype == np.float32
    assert error == float(r @ r) / r.size
    np.testing.assert_allclose(residual.shape(c, sim.params), aam.shape_instance(c, sim),
                               atol=1e-9)
    moved = Similarity(sim.a, sim.b, sim.tx + 4.0, sim.ty)
    assert residual(image, c, moved.params)[1] > 1.5 * error


def test_image_textures_are_normalised(synthetic_aam, synthetic_faces) -> None:
    residual = ResidualFunction(synthetic_aam)
    sample = synthetic_faces.test[0]
    g = residual.image_texture(synthetic_aam.prepare_image(sample.load_image()), sample.points)
    assert abs(float(g.mean())) < 1e-4 and abs(float(g.std()) - 1.0) < 1e-3
    flat = residual.image_texture(np.full((160, 160), 128, np.uint8), sample.points)
    assert np.all(flat == 0)  # no contrast: nothing to scale
