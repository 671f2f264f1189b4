"""Learning how to correct the parameters from a texture residual (thesis chapter 6).

Training images are sampled at perturbed parameters (Algorithm 4, the scheme
of table 6.1) and the residuals related to the perturbations, either by
principal component regression (Algorithm 5) or by estimating the Jacobian
``dr/dp`` and taking its SVD pseudo-inverse (Algorithm 6). The result, the
update matrix ``R`` with ``delta_p = R r``, is stored in the model file.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np

from aamcore.fitting.pyramid import pyramid
from aamcore.fitting.residuals import ResidualFunction
from aamcore.fitting.update_matrix import PerturbationScheme, UpdateMatrix
from aamcore.io import DatasetError, FaceSample
from aamcore.model.aam import AAM
from aamcore.model.similarity import Similarity

METHODS = ("jacobian", "regression")


TABLE_6_1 = PerturbationScheme()
"""The displacements of table 6.1."""
COARSE_SCHEME = PerturbationScheme(
    scales=(0.85, 0.92, 1.08, 1.18),
    angles_deg=(-20.0, -10.0, 10.0, 20.0),
    translations=(-0.3, -0.2, -0.1, -0.05, 0.05, 0.1, 0.2, 0.3),
)
"""Pose displacements for a coarse pyramid level, whose job is to bring far starts
near: up to 30 % of the face width. Measured on IMM (two folds, Haar start moved
40 px down) it cut failures from 11.7 % to 3.3 % against table 6.1's values doubled."""


def scheme_for_level(level: int) -> PerturbationScheme:
    """Table 6.1's scheme at full resolution, :data:`COARSE_SCHEME` (doubled per
    further level) below it."""
    return PerturbationScheme() if level == 0 else COARSE_SCHEME.widened(2.0 ** (level - 1))


def perturbed_residuals(
    aam: AAM,
    sample: FaceSample,
    displacements: np.ndarray,
    residual: ResidualFunction,
    level: int = 0,
) -> np.ndarray:
    """Residuals (E, M C) of one training image at each displacement (Algorithm 4).

    The pose displacement acts in the model frame: the perturbed shape is
    ``T_t(T_dt(x))``, so the fitter can undo it compositionally. ``level``
    halves the image that many times first (multi-resolution fitting).
    """
    raw = pyramid(sample.load_image(), level + 1)[level]
    factor = 0.5**level
    points = (sample.points + 0.5) * factor - 0.5
    c0, start = aam.parameters_of(raw, points)
    image = aam.prepare_image(raw, points)
    n_c = aam.n_appearance
    out = np.empty((len(displacements), aam.texture_basis.shape[0]), dtype=np.float32)
    for j, dp in enumerate(displacements):
        c = c0 + dp[:n_c]
        t = (start @ Similarity.from_params(dp[n_c:])).params
        out[j], _ = residual(image, c, t)
    return out


def _choose_images(
    samples: list[FaceSample], max_images: int | None, seed: int
) -> list[FaceSample]:
    """``samples``, or a random subset of ``max_images`` of them (in their order) if more."""
    chosen = list(samples)
    if max_images is not None and len(chosen) > max_images:
        rng = np.random.default_rng(seed)
        chosen = [chosen[i] for i in sorted(rng.choice(len(chosen), max_images, replace=False))]
    return chosen


def _solve_update(
    method: str,
    displacements: np.ndarray,
    used: int,
    gp: np.ndarray,
    blocks: list[np.ndarray],
    regression_variance: float,
) -> np.ndarray:
    """The update matrix ``R`` (t_c + 4, M C) from the accumulated experiments.

    Parameters
    ----------
    method : {"jacobian", "regression"}
    displacements : (E, t_c + 4) array
        The displacements tried on every image.
    used : int
        Images whose residuals were accumulated.
    gp : (M C, t_c + 4) array
        ``Delta_g Delta_p^T`` summed over the images (``"jacobian"``).
    blocks : list of (E, M C) arrays
        The residuals of each image (``"regression"``).
    regression_variance : float
        Fraction of the residual variance the regression keeps.
    """
    if method == "jacobian":
        pp = displacements.T @ displacements * used  # Delta_p Delta_p^T
        jacobian = gp @ np.linalg.inv(pp)
        return np.linalg.pinv(jacobian)
    dg = np.vstack(blocks).T.astype(np.float64)  # (m, s)
    dp = np.tile(displacements, (used, 1)).T  # (n_p, s)
    return principal_component_regression(dp, dg, regression_variance)


def train_update(
    aam: AAM,
    samples: list[FaceSample],
    method: str = "jacobian",
    scheme: PerturbationScheme = TABLE_6_1,
    max_images: int | None = 60,
    regression_variance: float = 0.99,
    seed: int = 0,
    level: int = 0,
    progress: Callable[[Iterable[FaceSample]], Iterable[FaceSample]] | None = None,
) -> UpdateMatrix:
    """Learn the update matrix from training ``samples``.

    Parameters
    ----------
    aam : AAM
    samples : list of FaceSample
        Training images (the ones the AAM was built from).
    method : {"jacobian", "regression"}
        Algorithm 6 (Jacobian and SVD pseudo-inverse) or Algorithm 5
        (principal component regression).
    scheme : PerturbationScheme
    max_images : int, optional
        Use a random subset of at most this many images.
    regression_variance : float
        Fraction of the residual variance the regression's principal
        components keep.
    seed : int
        Seed of the subset choice.
    level : int
        Pyramid level: train on images halved ``level`` times.
    progress : callable, optional
        Wraps the image iteration, e.g. ``tqdm``.
    """
    if method not in METHODS:
        raise ValueError(f"unknown update method {method!r}: choose one of {METHODS}")
    chosen = _choose_images(samples, max_images, seed)
    displacements = scheme.displacements(aam)
    residual = ResidualFunction(aam)
    n_p, m = displacements.shape[1], aam.texture_basis.shape[0]
    gp = np.zeros((m, n_p))  # accumulates Delta_g Delta_p^T
    blocks: list[np.ndarray] = []
    used = 0
    for sample in (progress or iter)(chosen):
        try:
            block = perturbed_residuals(aam, sample, displacements, residual, level)
        except DatasetError:
            continue
        used += 1
        if method == "jacobian":
            gp += block.T.astype(np.float64) @ displacements
        else:
            blocks.append(block)
    if used == 0:
        raise ValueError("no readable training image for the update training")
    R = _solve_update(method, displacements, used, gp, blocks, regression_variance)
    return UpdateMatrix(R.astype(np.float32), method, used, used * len(displacements), scheme)


def principal_component_regression(
    dp: np.ndarray, dg: np.ndarray, variance: float = 0.99
) -> np.ndarray:
    """``R = Delta_p Phi Lambda^-1 Phi^T Delta_g^T`` (eq. 6.18, Algorithm 5).

    Parameters
    ----------
    dp : (t_p, s) array
        Parameter displacements by column.
    dg : (m, s) array
        Texture residuals by column.
    variance : float
        Fraction of ``dg``'s variance the kept components explain.
    """
    eigenvalues, phi = np.linalg.eigh(dg.T @ dg)
    order = np.argsort(eigenvalues)[::-1]
    eigenvalues, phi = eigenvalues[order], phi[:, order]
    cumulative = np.cumsum(eigenvalues) / eigenvalues.sum()
    k = max(int(np.searchsorted(cumulative, variance) + 1), dp.shape[0])
    phi, eigenvalues = phi[:, :k], eigenvalues[:k]
    return (dp @ phi / eigenvalues) @ (phi.T @ dg.T)
