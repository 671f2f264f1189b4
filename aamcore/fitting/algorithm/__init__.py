"""Optimisation families for AAM fitting, one module each, and the registry of their names.

Every algorithm follows :class:`~aamcore.fitting.algorithm.base.Algorithm`:
``from_model(model, settings)`` does the costly precomputation once;
``run(image, c0, start)`` fits from an appearance and a placement and
``track(image, previous)`` from the previous frame's fit, on an image prepared
by its ``prepare`` (the AAM methods: :meth:`aamcore.model.aam.AAM.prepare_image`).
A new algorithm is one module here and one line in :data:`ALGORITHMS`.

``local-binary`` (the default) is a cascade of landmark-HOG and fern stages
in a shape space (``local_binary``, with ``local_hog`` and ``ferns``); the
others fit the AAM.

The registry names classes by path, so that reading the names (command-line
parsers) imports no algorithm code.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from aamcore.fitting.algorithm.base import Algorithm, AlgorithmSettings
    from aamcore.fitting.model import FittingModel

_PACKAGE = "aamcore.fitting.algorithm"
ALGORITHMS: dict[str, str] = {
    "local-binary": f"{_PACKAGE}.local_binary:LocalBinary",
    "supervised-descent": f"{_PACKAGE}.supervised_descent:SupervisedDescent",
    "fixed-jacobian": f"{_PACKAGE}.fixed_jacobian:FixedJacobian",
    "multi-resolution": f"{_PACKAGE}.multi_resolution:MultiResolution",
    "project-out-ic": f"{_PACKAGE}.project_out_ic:ProjectOutInverseCompositional",
}
"""Algorithm name -> ``module:Class``."""
REGRESSORS = ("local-binary",)
"""The landmark regressors: they return a :class:`~aamcore.fitting.result.LandmarkFit`,
without the AAM's appearance; every other method fits the AAM and returns an
:class:`~aamcore.fitting.result.AAMFit`."""


NEEDS: dict[str, tuple[str, str]] = {
    "local-binary": ("binary", "local-binary cascade"),
    "supervised-descent": ("cascade", "supervised-descent cascade"),
    "fixed-jacobian": ("updates", "update matrix"),
    "multi-resolution": ("updates", "update matrices"),
    "project-out-ic": ("", ""),
}
"""Algorithm name -> the part of the fitting model it reads (an attribute of
:class:`~aamcore.fitting.model.FittingModel`) and what that part is called."""


def missing_part(model: FittingModel, name: str) -> str:
    """Why ``model`` cannot be fitted by the algorithm ``name`` (one line), or ``""``."""
    if name not in ALGORITHMS:
        return f"unknown fitting algorithm {name!r}: choose one of {list(ALGORITHMS)}"
    part, called = NEEDS[name]
    if part and not getattr(model, part):
        return (f"this model has no {called}, which {name} needs: train it with "
                "`aamtrack train --fit` (or `aamtrack model prepare`)")
    return ""


def algorithm_class(name: str) -> type[Algorithm]:
    """The class of the algorithm called ``name``.

    Raises
    ------
    ValueError
        For an unknown name.
    """
    path = ALGORITHMS.get(name)
    if path is None:
        raise ValueError(f"unknown fitting algorithm {name!r}: choose one of {list(ALGORITHMS)}")
    module, cls = path.split(":")
    return getattr(importlib.import_module(module), cls)


def make_algorithm(name: str, model: FittingModel, settings: AlgorithmSettings) -> Algorithm:
    """The algorithm called ``name`` for ``model``.

    Raises
    ------
    ValueError
        For an unknown name, or a model that did not learn what the algorithm needs.
    """
    return algorithm_class(name).from_model(model, settings)
