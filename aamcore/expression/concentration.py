"""k-means concentration metric for choosing the Fisher directions kept (thesis 9.1.2).

After projecting the training data on its first ``k`` Fisher directions, the
data are clustered by k-means into as many clusters as there are classes.
Table 9.1 counts, for each class (row), how many of its samples fall in each
cluster (column). Eq 9.8 scores the clustering by how concentrated each class
is::

    D = sum_i  max(row_i) - min(row_i)

k-means only reaches a local optimum, so the experiment is repeated with
different initial centres; each trial names the ``k`` of highest ``D`` and
the most frequent winner over the trials is kept (the histogram of
figure 9.2).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sklearn.cluster import KMeans
from sklearn.discriminant_analysis import LinearDiscriminantAnalysis


def cluster_table(y_idx: np.ndarray, clusters: np.ndarray, n_classes: int) -> np.ndarray:
    """Table 9.1: samples of each class (rows) in each cluster (columns).

    Parameters
    ----------
    y_idx : (n,) int array
        Class index of each sample, in ``0..n_classes-1``.
    clusters : (n,) int array
        Cluster index of each sample, in ``0..n_classes-1``.

    Returns
    -------
    (n_classes, n_classes) int array
    """
    table = np.zeros((n_classes, n_classes), dtype=np.int64)
    np.add.at(table, (y_idx, clusters), 1)
    return table


def concentration_metric(table: np.ndarray) -> float:
    """Eq 9.8: sum over the rows of ``max(row) - min(row)`` of a table (n_classes, n_clusters)."""
    table = np.asarray(table)
    return float(np.sum(table.max(axis=1) - table.min(axis=1)))


@dataclass(frozen=True)
class ConcentrationStudy:
    """Eq 9.8 over repeated k-means trials for each candidate number of directions.

    Attributes
    ----------
    candidates : (m,) int array
        Numbers of Fisher directions tried, increasing.
    metrics : (n_trials, m) float array
        Eq 9.8 value of each trial and candidate.
    """

    candidates: np.ndarray
    metrics: np.ndarray

    def best_per_trial(self) -> np.ndarray:
        """Candidate of highest metric in each trial (the smaller on ties), shape (n_trials,)."""
        return self.candidates[np.argmax(self.metrics, axis=1)]

    def histogram(self) -> np.ndarray:
        """How many trials each candidate won, shape (m,) (figure 9.2)."""
        wins = np.argmax(self.metrics, axis=1)
        return np.bincount(wins, minlength=len(self.candidates))

    @property
    def best(self) -> int:
        """The candidate that won the most trials (the smaller on ties)."""
        return int(self.candidates[np.argmax(self.histogram())])


def concentration_study(
    X: np.ndarray,
    y: np.ndarray,
    candidates: np.ndarray | list[int] | None = None,
    n_trials: int = 25,
    random_state: int = 0,
    solver: str = "svd",
) -> ConcentrationStudy:
    """Run eq 9.8 for each candidate number of Fisher directions.

    Parameters
    ----------
    X : (n, d) float array
        Training features.
    y : (n,) array
        Class labels.
    candidates : sequence of int, optional
        Numbers of directions to try; by default ``1..n_classes-1``.
    n_trials : int
        Repetitions of k-means, each from a different random initialisation.
    random_state : int
        Seed of the first trial; trial t uses ``random_state + t``.
    solver : {"svd", "eigen"}
        LDA solver.
    """
    X = np.asarray(X, np.float64)
    classes, y_idx = np.unique(np.asarray(y), return_inverse=True)
    n_classes = len(classes)
    if n_classes < 2:
        raise ValueError(f"need at least 2 classes, got {n_classes}")
    if n_trials < 1:
        raise ValueError(f"n_trials must be at least 1, got {n_trials}")
    Z = LinearDiscriminantAnalysis(solver=solver).fit(X, y).transform(X)
    if candidates is None:
        candidates = np.arange(1, Z.shape[1] + 1)
    candidates = np.asarray(candidates, dtype=np.int64)
    if candidates.size == 0 or candidates.min() < 1 or candidates.max() > Z.shape[1]:
        raise ValueError(f"candidates must lie in 1..{Z.shape[1]}, got {candidates.tolist()}")
    metrics = np.empty((n_trials, len(candidates)))
    for t in range(n_trials):
        for j, k in enumerate(candidates):
            km = KMeans(n_clusters=n_classes, n_init=1, random_state=random_state + t)
            clusters = km.fit_predict(Z[:, :k])
            metrics[t, j] = concentration_metric(cluster_table(y_idx, clusters, n_classes))
    return ConcentrationStudy(candidates, metrics)


def choose_n_components(
    X: np.ndarray, y: np.ndarray, n_trials: int = 25, random_state: int = 0
) -> int:
    """Number of Fisher directions to keep for training data X (n, d), y (n,) by eq 9.8."""
    return concentration_study(X, y, n_trials=n_trials, random_state=random_state).best
