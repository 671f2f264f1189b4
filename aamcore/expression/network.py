"""A small network of face-feature vectors: scikit-learn training, numpy scoring.

The person-independent model must tell a neutral face from a faint expression of a
stranger, from one frame: a linear score of the HOG, shape and appearance blocks cannot
bend around the classes as a hidden layer can. :func:`fit_network` trains scikit-learn's
``MLPClassifier`` (one ReLU layer, Adam, L2 penalty) on block-scaled vectors
(:class:`~aamcore.expression.face_classifier.BlockScaler`), the classes weighted inversely
to their frequency as the logistic models' are, and returns :class:`NetworkModel`, a pure
numpy predictor of raw vectors that the classifier file stores as plain arrays.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from aamcore.expression.scores import FittedFaceClassifier, LinearModel

if TYPE_CHECKING:
    from aamcore.expression.face_classifier import BlockScaler

NETWORK_ARRAYS = ("mean", "scale", "hidden_coef", "hidden_intercept", "coef", "intercept")
"""The arrays of a stored :class:`NetworkModel`, by name."""


@dataclass(frozen=True, eq=False)
class NetworkModel:
    """Scores ``relu(((x - mean) / scale) @ hidden_coef + hidden_intercept) @ coef.T +
    intercept``.

    Attributes
    ----------
    mean, scale : (d,) float64 arrays
    hidden_coef : (d, h) float64 array
    hidden_intercept : (h,) float64 array
    coef : (n_classes, h) float64 array
    intercept : (n_classes,) float64 array
    """

    mean: np.ndarray
    scale: np.ndarray
    hidden_coef: np.ndarray
    hidden_intercept: np.ndarray
    coef: np.ndarray
    intercept: np.ndarray

    def __post_init__(self) -> None:
        d, h = self.hidden_coef.shape if self.hidden_coef.ndim == 2 else (-1, -1)
        if self.mean.shape != (d,) or self.scale.shape != (d,) \
                or self.hidden_intercept.shape != (h,):
            raise ValueError(f"mean {self.mean.shape}, scale {self.scale.shape}, hidden "
                             f"{self.hidden_coef.shape} + {self.hidden_intercept.shape}: need "
                             "(d,), (d,), (d, h) + (h,)")
        if self.coef.ndim != 2 or self.coef.shape[1] != h \
                or self.intercept.shape != (self.coef.shape[0],):
            raise ValueError(f"output {self.coef.shape} + {self.intercept.shape}: need "
                             f"(k, {h}) + (k,)")
        if not np.all(self.scale > 0):
            raise ValueError("scale must be > 0")

    @property
    def feature_dim(self) -> int:
        """Dimension d of the input vectors."""
        return self.hidden_coef.shape[0]

    @property
    def n_classes(self) -> int:
        return self.coef.shape[0]

    def scores(self, X: np.ndarray) -> np.ndarray:
        """Per-class scores of the rows of X (n, d), shape (n, n_classes)."""
        Z = (np.asarray(X, np.float64) - self.mean).astype(np.float32)
        hidden = np.maximum(Z @ self._hidden_weights + self.hidden_intercept, 0.0)
        return hidden @ self.coef.T + self.intercept

    @cached_property
    def _hidden_weights(self) -> np.ndarray:
        """The hidden layer's weights divided by the scale (d, h), float32:
        half the bytes of the largest array, read at every frame after the fitter has
        filled the caches with its own (the stack's expression stage ran 1.5x slower than
        alone), at rounding of a few parts in a million of the scores."""
        weights = (self.hidden_coef / self.scale[:, None]).astype(np.float32)
        weights.setflags(write=False)
        return weights

    def shifted(self, offset: np.ndarray) -> NetworkModel:
        """The same network with ``offset`` (n_classes,) added to every row's scores."""
        return replace(self, intercept=self.intercept + np.asarray(offset, np.float64))

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The arrays to store, by name."""
        return {name: getattr(self, name) for name in NETWORK_ARRAYS}

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray]) -> NetworkModel:
        """Rebuild from :meth:`to_arrays` output; KeyError or ValueError when inconsistent."""
        return cls(*(np.asarray(arrays[k], np.float64) for k in NETWORK_ARRAYS))


def stored_model(arrays: Mapping[str, np.ndarray]) -> LinearModel | NetworkModel:
    """The linear model or network of stored arrays (a network's have a hidden layer);
    KeyError or ValueError when inconsistent."""
    if set(NETWORK_ARRAYS) <= set(arrays):
        return NetworkModel.from_arrays(arrays)
    return LinearModel.from_arrays(arrays)


def fit_network(
    X: np.ndarray,
    y: np.ndarray,
    block_dims: Mapping[str, int],
    hidden: int = 256,
    alpha: float = 1e-2,
    epochs: int = 60,
    seed: int = 0,
    sample_weight: np.ndarray | None = None,
    seeds: int = 1,
    threads: int = 1,
) -> FittedFaceClassifier:
    """A one-hidden-layer network of block-scaled vectors, classes weighted alike; with
    ``seeds`` > 1 the average of the scores of that many networks, stored as one network.

    Parameters
    ----------
    X : (n, d) float array
    y : (n,) array of str
    block_dims : mapping str -> int
        Block names and lengths in vector order (sum d).
    hidden : int
        Units of the hidden layer (of each network).
    alpha : float
        L2 penalty of the weights.
    epochs : int
        Passes over the (resampled) rows; the solver stops there, converged or not.
    seed : int
        Of the initial weights and the batches: the same data give the same network.
    sample_weight : (n,) float array, optional
        Times the class weights.
    seeds : int
        Networks trained from seeds ``seed``, ``seed + 1``, ...: their hidden layers side by
        side and their output weights divided by ``seeds`` score the mean of their scores,
        so the ensemble is one :class:`NetworkModel` of ``seeds * hidden`` units.
    threads : int
        Networks trained at once (the same ensemble however many).
    """
    if seeds < 1:
        raise ValueError(f"seeds must be >= 1, got {seeds}")
    y = np.asarray(y).astype(str)
    scaler, gain, Z, weight = _scaled(X, y, block_dims, sample_weight)
    with ThreadPoolExecutor(max(1, min(threads, seeds))) as pool:
        layers = list(pool.map(lambda k: _one_network(Z, y, weight, hidden, alpha, epochs,
                                                      seed + k), range(seeds)))
    model = NetworkModel(scaler.mean_.copy(), scaler.scale_ / gain,
                         np.hstack([layer[1] for layer in layers]),
                         np.concatenate([layer[2] for layer in layers]),
                         np.hstack([layer[3] for layer in layers]) / seeds,
                         np.mean([layer[4] for layer in layers], axis=0))
    return FittedFaceClassifier(model, layers[0][0], "network",
                                {"classifier": "network", "hidden": hidden, "alpha": alpha,
                                 "epochs": epochs, "seeds": seeds})


def _scaled(X: np.ndarray, y: np.ndarray, block_dims: Mapping[str, int],
            sample_weight: np.ndarray | None
            ) -> tuple[BlockScaler, float, np.ndarray, np.ndarray]:
    """The block scaler of X (n, d), its gain, the rows it scales (n, d) and their weights
    (n,): the classes weighted alike, times ``sample_weight``."""
    from sklearn.utils.class_weight import compute_sample_weight  # serving never imports it

    from aamcore.expression.face_classifier import BlockScaler

    X = np.asarray(X, np.float64)
    scaler = BlockScaler(tuple(block_dims.items())).fit(X)
    # Each block's variance is 1 / len(blocks) after the scaler: a unit total per block
    # suits the network's default initialisation.
    gain = float(np.sqrt(len(block_dims)))
    weight = compute_sample_weight("balanced", y)
    if sample_weight is not None:
        weight = weight * np.asarray(sample_weight, np.float64)
    return scaler, gain, scaler.transform(X) * gain, weight


def _one_network(Z: np.ndarray, y: np.ndarray, weight: np.ndarray, hidden: int, alpha: float,
                 epochs: int, seed: int
                 ) -> tuple[tuple[str, ...], np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The classes and the weights of one network of scaled rows Z (n, d): hidden (d, h) and
    (h,), output (k, h) and (k,)."""
    from sklearn.exceptions import ConvergenceWarning
    from sklearn.neural_network import MLPClassifier

    # Stopping at ``epochs`` is meant. A filter for that message alone, not catch_warnings,
    # whose save and restore of the global filters races between threads.
    warnings.filterwarnings("ignore", "Stochastic Optimizer: Maximum iterations",
                            ConvergenceWarning)
    net = MLPClassifier((hidden,), alpha=alpha, max_iter=epochs, random_state=seed,
                        batch_size=min(128, len(Z)))
    net.fit(Z, y, sample_weight=weight)
    (w1, w2), (b1, b2) = net.coefs_, net.intercepts_
    classes = tuple(str(c) for c in net.classes_)
    if len(classes) == 2:  # one logistic output: the second class's score, as +/- halves
        w2, b2 = np.hstack([-w2, w2]) / 2.0, np.array([-b2[0], b2[0]]) / 2.0
    return classes, w1, b1, w2.T.copy(), b2
