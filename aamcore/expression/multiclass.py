"""Multi-class decisions from binary machine outputs (thesis section 10.1.2).

Every scheme turns the decision values of the binary machines, shape
``(n, n_machines)``, into per-class scores, shape ``(n, n_classes)``, whose
argmax is the predicted class:

- one-against-all: machine ``i`` separates class ``i`` from the rest; the
  score of class ``i`` is its decision value (eq 10.7).
- one-against-one ("max wins"): every pairwise machine votes; the score is
  the vote count plus a confidence term below 1/3 that breaks ties in favour
  of the class with the larger summed decision values.
- DAG (Platt, Cristianini and Shawe-Taylor 2000): the classes form a list;
  the machine of the first and last classes removes the loser, until one
  class remains, after ``n_classes - 1`` evaluations. A class removed at step
  ``s`` (0-based) scores ``s / (n_classes - 1)``; the survivor scores 1, so
  the ranking follows the order of elimination.
"""

from __future__ import annotations

import numpy as np

SCHEMES = ("ova", "ovo", "dag")
"""One-against-all, one-against-one, decision DAG."""


def pair_index(positive: np.ndarray, negative: np.ndarray, n_classes: int) -> np.ndarray:
    """(n_classes, n_classes) int array: the machine of each class pair, -1 where none."""
    index = np.full((n_classes, n_classes), -1, dtype=np.int64)
    for m, (i, j) in enumerate(zip(positive, negative, strict=True)):
        index[i, j] = index[j, i] = m
    return index


def ova_scores(values: np.ndarray) -> np.ndarray:
    """One-against-all: the decision values (n, n_classes) themselves."""
    return values


def ovo_scores(
    values: np.ndarray, positive: np.ndarray, negative: np.ndarray, n_classes: int
) -> np.ndarray:
    """Max-wins votes of pairwise machines, with a tie-breaking confidence, (n, n_classes)."""
    machines = np.arange(len(positive))
    pos = np.zeros((len(positive), n_classes))
    neg = np.zeros((len(positive), n_classes))
    pos[machines, positive] = 1.0
    neg[machines, negative] = 1.0
    wins = (values > 0).astype(np.float64)
    votes = wins @ pos + (1.0 - wins) @ neg
    confidence = values @ (pos - neg)
    return votes + confidence / (3.0 * (np.abs(confidence) + 1.0))


def dag_scores(values: np.ndarray, positive: np.ndarray, index: np.ndarray) -> np.ndarray:
    """Decision-DAG elimination scores, (n, n_classes), from pairwise values (n, n_machines).

    Parameters
    ----------
    values : (n, n_machines) array
        Pairwise decision values, positive for the machine's ``positive`` class.
    positive : (n_machines,) int array
        The class each machine's positive side stands for.
    index : (n_classes, n_classes) int array
        From :func:`pair_index`: the machine of each class pair.
    """
    n, n_classes = len(values), len(index)
    scores = np.ones((n, n_classes))
    for row in range(n):
        alive = list(range(n_classes))
        for step in range(n_classes - 1):
            i, j = alive[0], alive[-1]
            m = index[i, j]
            i_wins = (values[row, m] > 0) == (positive[m] == i)
            loser = j if i_wins else i
            scores[row, loser] = step / (n_classes - 1)
            alive.remove(loser)
    return scores
