"""The update matrix of the AAM methods, as a fitting model holds it (thesis chapter 6).

:class:`UpdateMatrix` (``delta_p = R r``) and the :class:`PerturbationScheme` it was
learned with are what the fixed-Jacobian methods read and the model file stores; how they
are learned is :mod:`aamcore.fitting.training.update` (running code imports none of it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aamcore.model.aam import AAM


@dataclass(frozen=True)
class PerturbationScheme:
    """Displacements tried per parameter, one parameter at a time (table 6.1).

    Attributes
    ----------
    appearance_sigmas : tuple of float
        Multiples of each appearance parameter's standard deviation.
    scales : tuple of float
        Relative scales.
    angles_deg : tuple of float
        Rotations in degrees.
    translations : tuple of float
        Shifts in x and in y, as fractions of the reference shape's width.
    """

    appearance_sigmas: tuple[float, ...] = (-0.5, -0.25, 0.25, 0.5)
    scales: tuple[float, ...] = (0.9, 1.1)
    angles_deg: tuple[float, ...] = (-10.0, -5.0, 5.0, 10.0)
    translations: tuple[float, ...] = (-0.10, -0.05, 0.05, 0.10)

    def widened(self, factor: float) -> PerturbationScheme:
        """The scheme with pose displacements ``factor`` times larger (coarse pyramid levels)."""
        return PerturbationScheme(
            self.appearance_sigmas,
            tuple(float(np.exp(np.log(s) * factor)) for s in self.scales),
            tuple(a * factor for a in self.angles_deg),
            tuple(d * factor for d in self.translations),
        )

    def displacements(self, aam: AAM) -> np.ndarray:
        """All displacement vectors ``delta_p = (delta_c, delta_t)``, shape (E, t_c + 4)."""
        n_c = aam.n_appearance
        sigma = np.sqrt(aam.combined.pca.variances)
        width = float(np.ptp(aam.shape.mean_shape[:, 0]))
        rows = []
        for i in range(n_c):
            for k in self.appearance_sigmas:
                dp = np.zeros(n_c + 4)
                dp[i] = k * sigma[i]
                rows.append(dp)
        for s in self.scales:
            rows.append(np.r_[np.zeros(n_c), s - 1.0, 0.0, 0.0, 0.0])
        for a in np.radians(self.angles_deg):
            rows.append(np.r_[np.zeros(n_c), np.cos(a) - 1.0, np.sin(a), 0.0, 0.0])
        for d in self.translations:
            rows.append(np.r_[np.zeros(n_c), 0.0, 0.0, d * width, 0.0])
            rows.append(np.r_[np.zeros(n_c), 0.0, 0.0, 0.0, d * width])
        return np.array(rows)


@dataclass(frozen=True)
class UpdateMatrix:
    """The learned update ``delta_p = R r``.

    Attributes
    ----------
    R : (t_c + 4, M C) float32 array
    method : str
        ``"jacobian"`` or ``"regression"``.
    images : int
        Training images used.
    experiments : int
        Perturbed samples used.
    scheme : PerturbationScheme
        The displacements it was trained on.
    """

    R: np.ndarray
    method: str
    images: int
    experiments: int
    scheme: PerturbationScheme = PerturbationScheme()
