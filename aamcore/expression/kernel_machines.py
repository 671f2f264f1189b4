"""A set of binary RBF support vector machines held as plain arrays.

scikit-learn's :class:`~sklearn.svm.SVC` trains each binary machine; its
support vectors, dual coefficients and intercept are then copied into one
:class:`RBFMachines` so that the decision values of all machines come from a
few numpy operations, and so that they can be saved without pickle.

Machine ``m`` separates class ``positive[m]`` (decision > 0) from class
``negative[m]``, or from all other classes when ``negative[m] == -1``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sklearn.svm import SVC

REST = -1
"""``negative`` value of a one-against-all machine."""


@dataclass(frozen=True)
class RBFMachines:
    """Binary RBF machines sharing one ``gamma``.

    Attributes
    ----------
    support_vectors : (n_sv, d) float64 array
        Support vectors of all machines, machine after machine.
    dual_coef : (n_sv,) float64 array
        ``alpha_i * y_i`` of each support vector.
    offsets : (n_machines + 1,) int64 array
        Machine ``m`` owns rows ``offsets[m]:offsets[m+1]``.
    intercepts : (n_machines,) float64 array
    positive, negative : (n_machines,) int64 arrays
        Class indices on each side; ``negative == -1`` means all others.
    gamma : float
        RBF kernel ``exp(-gamma * ||x - s||^2)``.
    """

    support_vectors: np.ndarray
    dual_coef: np.ndarray
    offsets: np.ndarray
    intercepts: np.ndarray
    positive: np.ndarray
    negative: np.ndarray
    gamma: float

    def __post_init__(self) -> None:
        n_machines = len(self.intercepts)
        if self.offsets.shape != (n_machines + 1,) or self.offsets[0] != 0:
            raise ValueError(f"offsets {self.offsets.shape} do not describe {n_machines} machines")
        if np.any(np.diff(self.offsets) <= 0) or self.offsets[-1] != len(self.support_vectors):
            raise ValueError("every machine needs at least one support vector")
        if self.dual_coef.shape != (len(self.support_vectors),):
            raise ValueError(f"dual_coef has shape {self.dual_coef.shape}")
        if self.positive.shape != (n_machines,) or self.negative.shape != (n_machines,):
            raise ValueError("positive and negative need one entry per machine")
        if not self.gamma > 0:
            raise ValueError(f"gamma must be positive, got {self.gamma}")
        sv = self.support_vectors
        # Frozen dataclass: cache the squared norms used by every kernel evaluation.
        object.__setattr__(self, "_sv_sqnorm", np.einsum("ij,ij->i", sv, sv))

    @property
    def n_machines(self) -> int:
        """Number of binary machines."""
        return len(self.intercepts)

    def decision_values(self, X: np.ndarray) -> np.ndarray:
        """Decision value of every machine for every row of X (n, d), shape (n, n_machines)."""
        sq = np.einsum("ij,ij->i", X, X)[:, None] + self._sv_sqnorm[None, :]
        sq -= 2.0 * (X @ self.support_vectors.T)
        weighted = np.exp(-self.gamma * np.maximum(sq, 0.0)) * self.dual_coef
        return np.add.reduceat(weighted, self.offsets[:-1], axis=1) + self.intercepts

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The arrays to store, by name (gamma as a 0-d array)."""
        return {
            "support_vectors": self.support_vectors,
            "dual_coef": self.dual_coef,
            "offsets": self.offsets,
            "intercepts": self.intercepts,
            "positive": self.positive,
            "negative": self.negative,
            "gamma": np.asarray(self.gamma, np.float64),
        }

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> RBFMachines:
        """Rebuild from :meth:`to_arrays` output; raises ValueError on inconsistent arrays."""
        f64 = {k: np.asarray(arrays[k], np.float64) for k in ("support_vectors", "dual_coef")}
        i64 = {k: np.asarray(arrays[k], np.int64) for k in ("offsets", "positive", "negative")}
        sv = f64["support_vectors"]
        if sv.ndim != 2:
            raise ValueError(f"support_vectors must be 2-D, got shape {sv.shape}")
        return cls(
            support_vectors=sv,
            dual_coef=f64["dual_coef"],
            offsets=i64["offsets"],
            intercepts=np.asarray(arrays["intercepts"], np.float64),
            positive=i64["positive"],
            negative=i64["negative"],
            gamma=float(np.asarray(arrays["gamma"])),
        )


_Part = tuple[np.ndarray, np.ndarray, float]


def _assemble(parts: list[_Part], pairs: list[tuple[int, int]], gamma: float) -> RBFMachines:
    """Stack per-machine (support vectors, dual coefficients, intercept) into one RBFMachines."""
    sizes = [len(p[1]) for p in parts]
    return RBFMachines(
        support_vectors=np.concatenate([p[0] for p in parts]),
        dual_coef=np.concatenate([p[1] for p in parts]),
        offsets=np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64),
        intercepts=np.array([p[2] for p in parts], np.float64),
        positive=np.array([p[0] for p in pairs], np.int64),
        negative=np.array([p[1] for p in pairs], np.int64),
        gamma=float(gamma),
    )


def fit_one_against_all(
    X: np.ndarray, y_idx: np.ndarray, n_classes: int, C: float, gamma: float
) -> RBFMachines:
    """One machine per class against all others (eq 10.5) on X (n, d), class indices y_idx (n,)."""
    parts: list[_Part] = []
    for c in range(n_classes):
        svc = SVC(kernel="rbf", C=C, gamma=gamma).fit(X, (y_idx == c).astype(np.int64))
        if len(svc.classes_) != 2:
            raise ValueError(f"class {c} has no samples, or is the only class, in the training set")
        # Binary SVC: decision > 0 means classes_[1], here 1 = class c.
        parts.append((svc.support_vectors_, svc.dual_coef_[0], float(svc.intercept_[0])))
    return _assemble(parts, [(c, REST) for c in range(n_classes)], gamma)


def fit_pairwise(
    X: np.ndarray, y_idx: np.ndarray, n_classes: int, C: float, gamma: float
) -> RBFMachines:
    """The ``n_classes (n_classes - 1) / 2`` pairwise machines (eq 10.8).

    One multi-class SVC (libsvm trains exactly these machines, each on the
    samples of its two classes) is unpacked into separate machines.
    """
    svc = SVC(kernel="rbf", C=C, gamma=gamma).fit(X, y_idx)
    if len(svc.classes_) != n_classes:
        raise ValueError(f"the training set has {len(svc.classes_)} classes, expected {n_classes}")
    starts = np.concatenate([[0], np.cumsum(svc.n_support_)])
    rows = [np.arange(starts[c], starts[c + 1]) for c in range(n_classes)]
    parts: list[_Part] = []
    pairs = [(i, j) for i in range(n_classes) for j in range(i + 1, n_classes)]
    for p, (i, j) in enumerate(pairs):
        # libsvm layout: coefficients of class i's vectors against class j sit in row j - 1,
        # those of class j's vectors against class i in row i.
        idx = np.concatenate([rows[i], rows[j]])
        coef = np.concatenate([svc.dual_coef_[j - 1, rows[i]], svc.dual_coef_[i, rows[j]]])
        used = coef != 0
        if not used.any():
            used[0] = True
        parts.append((svc.support_vectors_[idx[used]], coef[used], float(svc.intercept_[p])))
    return _assemble(parts, pairs, gamma)
