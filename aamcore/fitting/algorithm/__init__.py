"""Optimisation families for AAM fitting, one module each.

Every algorithm offers ``run(image, c0, t0) -> FitResult`` and
``track(image, previous: FitResult) -> FitResult`` on a prepared image (see
:meth:`aamcore.model.aam.AAM.prepare_image`), with all costly precomputation in its
constructor; ``track`` starts from the previous frame's fit in whatever way
suits the algorithm (its parameters, its landmarks, or its pose).
"""

from aamcore.fitting.algorithm.fixed_jacobian import FixedJacobian
from aamcore.fitting.algorithm.multi_resolution import MultiResolution
from aamcore.fitting.algorithm.project_out_ic import ProjectOutInverseCompositional
from aamcore.fitting.algorithm.supervised_descent import SupervisedDescent

__all__ = [
    "FixedJacobian",
    "MultiResolution",
    "ProjectOutInverseCompositional",
    "SupervisedDescent",
]
