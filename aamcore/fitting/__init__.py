"""Fitting an AAM to an image (thesis chapters 6 and 7).

- ``residuals``: the texture residual of a model instance against an image.
- ``update_training``: learning the update matrix from perturbed training
  images, by regression (Algorithm 5) or through the Jacobian (Algorithm 6).
- ``descent_training`` and ``features``: the learned cascade on HOG features.
- ``algorithm/``: one module per optimisation family:
  ``FixedJacobian`` (damped Gauss-Newton of Algorithm 7),
  ``ProjectOutInverseCompositional`` (Matthews & Baker 2004) and
  ``SupervisedDescent`` (cascaded regression, beyond the thesis).
- ``result``: what a fit returns.
- ``fitter``: training what fitting needs (:func:`prepare_fitting`), the
  :class:`Fitter` facade and the frame-to-frame :class:`Tracker`.
"""

from aamcore.fitting.result import FitResult

__all__ = ["FitResult"]
