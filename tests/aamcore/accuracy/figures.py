"""Figures the small test model of the recipe measured, each with its tolerance.

The recipe is deterministic on a machine (``tests/aamcore/test_reproducible.py``), but not
across machines (another CPU's BLAS kernels change the shape model in its last digits, and
a fern's threshold then lands on the other side of a pixel difference: see
``tests/expectations.py``); the tolerances leave room for that spread, and no more.

A change that moves a figure beyond its tolerance, for the better or the worse, fails its
test. When the move is meant (a new recipe, a new classifier), run the failing test: its
message gives the figure measured; write it here in the same commit, and say in the commit
message what moved it.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Recorded:
    """A figure as recorded, and how far a run may stray from it.

    Attributes
    ----------
    name : str
        What is measured, as the failure message says it.
    value : float
    tolerance : float
        The most a run may differ from ``value``, in the figure's own units.
    lower_is_better : bool
    """

    name: str
    value: float
    tolerance: float
    lower_is_better: bool = True

    def check(self, measured: float) -> None:
        """Fail, saying which way and what to do, when ``measured`` strays from the figure."""
        worse = measured - self.value if self.lower_is_better else self.value - measured
        where = f"{__name__.replace('.', '/')}.py"
        assert worse <= self.tolerance, (
            f"{self.name}: {measured:.4f}, worse than the recorded {self.value:.4f} by more "
            f"than its tolerance {self.tolerance:.4f} (only if the change means it, as a trade "
            f"stated in its commit: record {measured:.4f} in {where})")
        assert worse >= -self.tolerance, (
            f"{self.name}: {measured:.4f}, better than the recorded {self.value:.4f} by more "
            f"than its tolerance {self.tolerance:.4f}: if the change meant it, record "
            f"{measured:.4f} in {where}")


# Measured with the test model of cascade seed 0 and of seed 2 (in brackets): 0.0588 (0.0592),
# 0.652 (0.659), 0.034 (0.037), 0.429 (0.413), 0.0552 (0.0583). The tolerances are three to ten
# times those spreads; a model trained with half the cascade's stages measured 0.0632.
# Recipe fitting v15 (a quarter of the cascade's samples read on a copy of their face with an
# occluder drawn over it) measured 0.0605, 0.7133, 0.0244, 0.4516 and 0.0570 for the five
# figures below, in their order (v14: 0.0588, 0.6517, 0.0335, 0.4560, 0.0552): the flags gain
# beyond their tolerance, the clean faces' landmarks lose within theirs.
HELD_OUT_NME = Recorded("mean NME of the held-out slice from the Haar box", 0.0605, 0.004)
OCCLUDED_FLAGGED = Recorded("share of the covered landmarks flagged", 0.7133, 0.04,
                            lower_is_better=False)
VISIBLE_FLAGGED = Recorded("share of the visible landmarks flagged beside an occluder", 0.0244,
                           0.015)
# The held-out expressions: 0.4560 with the person-independent network of HOG, shape and
# appearance (issue 46; main's logistic model of HOG and shape measured 0.4160 with the same
# test model on that machine, 0.4286 recorded before).
HELD_OUT_EXPRESSIONS = Recorded("share of the held-out people's faces labelled right", 0.4516,
                                0.06, lower_is_better=False)
TRACKED_NME = Recorded("mean NME of the tracked frames of two held-out faces", 0.0570, 0.01)
