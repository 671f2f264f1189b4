"""A face's reference feature vector, an estimate of the person's neutral face: a running
median of the faces that look neutral.

Expression vectors taken relative to the reference (``vector - reference``)
remove much of what differs between people. The expression service keeps one
:class:`NeutralReference` per stream and offers it every classifiable face with the
probability the person-independent model gives it of being neutral; the reference keeps
only the faces that look neutral enough (``min_neutral``), so that a long smile or cry
does not become the face the others are measured against. The benchmark and the training
give each person the median of their faces that look neutral (:func:`poser_references`).
"""

from __future__ import annotations

import collections
from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class NeutralReference:
    """The per-feature median of the vectors kept: every ``stride``-th vector offered,
    the last ``window`` of them (all when ``window`` is ``None``).

    Parameters
    ----------
    window : int or None
        Most vectors kept; ``None`` keeps all.
    stride : int
        Keep one vector in ``stride`` (consecutive video frames are nearly
        equal; spacing them makes the window span more of the stream).
    min_count : int
        Vectors needed before :attr:`ready` is true.
    min_neutral : float
        Smallest probability of being neutral of a vector kept (0: every vector); a vector
        below it is not offered at all (nor counted for the stride).
    """

    window: int | None = None
    stride: int = 1
    min_count: int = 1
    min_neutral: float = 0.0
    _kept: collections.deque[np.ndarray] = field(init=False, repr=False)
    _seen: int = field(default=0, init=False, repr=False)
    _median: np.ndarray | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        if self.window is not None and self.window < 1:
            raise ValueError(f"window must be >= 1 or None, got {self.window}")
        if self.stride < 1 or self.min_count < 1:
            raise ValueError("stride and min_count must be >= 1")
        if self.window is not None and self.min_count > self.window:
            raise ValueError(f"min_count {self.min_count} is more than the window {self.window}")
        if not 0.0 <= self.min_neutral <= 1.0:
            raise ValueError(f"min_neutral must be a probability, got {self.min_neutral}")
        self._kept = collections.deque(maxlen=self.window)

    def update(self, features: np.ndarray, neutral: float = 1.0) -> bool:
        """Offer one feature vector (d,) with its probability of being neutral; True when it
        was kept.

        Raises
        ------
        ValueError
            For a vector of another length than the ones kept, or non-finite.
        """
        features = np.asarray(features, np.float64).ravel()
        if self._kept and features.shape != self._kept[0].shape:
            raise ValueError(
                f"feature vector of length {features.size}, the reference has {self._kept[0].size}"
            )
        if not np.all(np.isfinite(features)):
            raise ValueError("non-finite feature vector")
        if neutral < self.min_neutral:
            return False
        keep = self._seen % self.stride == 0
        self._seen += 1
        if keep:
            self._kept.append(features.copy())
            self._median = None
        return keep

    @property
    def count(self) -> int:
        """Vectors in the window."""
        return len(self._kept)

    @property
    def ready(self) -> bool:
        """At least ``min_count`` vectors kept."""
        return len(self._kept) >= self.min_count

    def reference(self) -> np.ndarray:
        """The per-feature median (d,) of the vectors kept.

        Raises
        ------
        ValueError
            Before any vector was kept.
        """
        if not self._kept:
            raise ValueError("no feature vector yet: the reference is unknown")
        if self._median is None:
            self._median = np.median(np.stack(self._kept), axis=0)
        return self._median

    def reset(self) -> None:
        """Forget every vector (a new face or stream)."""
        self._kept.clear()
        self._seen = 0
        self._median = None

    def to_json(self) -> dict[str, Any]:
        """The settings (not the state) as a JSON-serialisable dict."""
        return {"window": self.window, "stride": self.stride, "min_count": self.min_count,
                "min_neutral": self.min_neutral}


def median_of(X: np.ndarray) -> np.ndarray:
    """The reference (d,) of the rows of X (n, d): a :class:`NeutralReference` fed all of them."""
    reference = NeutralReference()
    for row in X:
        reference.update(row)
    return reference.reference()


def poser_references(
    X: np.ndarray,
    posers: np.ndarray,
    usable: np.ndarray | None = None,
    causal_order: np.ndarray | None = None,
) -> np.ndarray:
    """Each face's unsupervised reference: a :class:`NeutralReference` of its poser's faces.

    Parameters
    ----------
    X : (n, d) array
        Feature vectors.
    posers : (n,) array
        Poser (stream) of each vector.
    usable : (n,) bool array, optional
        Vectors that may enter a reference (the classifiable faces); all by default.
    causal_order : (n,) int array, optional
        When given, each poser's faces are fed in increasing ``causal_order``
        and each face gets the reference of the faces fed up to and including
        itself (what a stream would have at that moment). Without it every
        face gets the median of all its poser's usable faces.

    Returns
    -------
    (n, d) float64 array
        Rows of faces whose poser has no usable face, and (causal) of
        unusable faces, are zero.
    """
    X = np.asarray(X, np.float64)
    posers = np.asarray(posers).astype(str)
    usable = np.ones(len(X), bool) if usable is None else np.asarray(usable, bool)
    out = np.zeros_like(X)
    for poser in np.unique(posers):
        members = np.flatnonzero((posers == poser) & usable)
        if members.size == 0:
            continue
        if causal_order is None:
            out[posers == poser] = median_of(X[members])
            continue
        reference = NeutralReference()
        for i in members[np.argsort(np.asarray(causal_order)[members], kind="stable")]:
            reference.update(X[i])
            out[i] = reference.reference()
    return out
