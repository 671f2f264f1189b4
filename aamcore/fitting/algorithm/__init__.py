"""Optimisation families for AAM fitting, one module each, and the registry of their names.

Every algorithm follows :class:`~aamcore.fitting.algorithm.base.Algorithm`:
``from_model(model, settings)`` does the costly precomputation once;
``run(image, c0, start)`` fits from an appearance and a placement and
``track(image, previous)`` from the previous frame's fit, on a prepared image
(see :meth:`aamcore.model.aam.AAM.prepare_image`). A new algorithm is one
module here and one line in :data:`ALGORITHMS`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from aamcore.fitting.algorithm.base import Algorithm, AlgorithmSettings
from aamcore.fitting.algorithm.fixed_jacobian import FixedJacobian
from aamcore.fitting.algorithm.multi_resolution import MultiResolution
from aamcore.fitting.algorithm.project_out_ic import ProjectOutInverseCompositional
from aamcore.fitting.algorithm.supervised_descent import SupervisedDescent

if TYPE_CHECKING:
    from aamcore.fitting.model import FittingModel

ALGORITHMS: dict[str, type[Algorithm]] = {
    "supervised-descent": SupervisedDescent,
    "fixed-jacobian": FixedJacobian,
    "multi-resolution": MultiResolution,
    "project-out-ic": ProjectOutInverseCompositional,
}
"""Algorithm name -> class."""


def make_algorithm(name: str, model: FittingModel, settings: AlgorithmSettings) -> Algorithm:
    """The algorithm called ``name`` for ``model``.

    Raises
    ------
    ValueError
        For an unknown name, or a model that did not learn what the algorithm needs.
    """
    cls = ALGORITHMS.get(name)
    if cls is None:
        raise ValueError(f"unknown fitting algorithm {name!r}: choose one of {list(ALGORITHMS)}")
    return cls.from_model(model, settings)


__all__ = [
    "ALGORITHMS",
    "Algorithm",
    "AlgorithmSettings",
    "FixedJacobian",
    "MultiResolution",
    "ProjectOutInverseCompositional",
    "SupervisedDescent",
    "make_algorithm",
]
