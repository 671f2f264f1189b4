import numpy as np
import pytest

from aamcore.model.pca import fit_pca, modes_for_variance


def _shapes(imm_set) -> np.ndarray:
    return np.stack([s.points.ravel() for s in imm_set.samples])


def test_reconstruction_error_matches_discarded_variance(imm_set) -> None:
    data = _shapes(imm_set)
    full = fit_pca(data, 1.0)
    errors = []
    for k in (1, 3, 6, 12, 24):
        model = full.truncated(k)
        recon = model.reconstruct(model.project(data))
        mse = np.sum((recon - data) ** 2) / (len(data) - 1)
        errors.append(mse)
        assert mse == pytest.approx(full.variances[k:].sum(), rel=1e-6)
    assert errors == sorted(errors, reverse=True)


def test_low_memory_path_agrees(imm_set) -> None:
    data = _shapes(imm_set)[:20]  # 20 samples, 146 dims: the Gram path
    small = fit_pca(data, 0.99)
    cov = np.cov(data.T)
    eig = np.sort(np.linalg.eigvalsh(cov))[::-1][: small.n_modes]
    np.testing.assert_allclose(small.variances, eig, rtol=1e-8)
    np.testing.assert_allclose(
        small.components.T @ small.components, np.eye(small.n_modes), atol=1e-9
    )


def test_modes_for_variance() -> None:
    eig = np.array([5.0, 3.0, 1.0, 1.0])
    assert modes_for_variance(eig, 0.5) == 1
    assert modes_for_variance(eig, 0.8) == 2
    assert modes_for_variance(eig, 1.0) == 4
    with pytest.raises(ValueError):
        modes_for_variance(eig, 1.5)
    with pytest.raises(ValueError, match="at least 2"):
        fit_pca(np.ones((1, 3)))
