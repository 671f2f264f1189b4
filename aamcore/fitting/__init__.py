"""Fitting an AAM to an image (thesis chapters 6 and 7).

- ``model``: the :class:`~aamcore.fitting.model.FittingModel`, an AAM with
  everything its algorithms learned, saved in one file.
- ``algorithm/``: one module per optimisation family and the registry of their names.
- ``fitter``: :class:`~aamcore.fitting.fitter.Fitter`, one model and one
  algorithm, started from a box, a shape or parameters; ``tracker``: frame to
  frame with re-detection.
- ``failure``: how a failed fit is recognised; ``result``: what a fit returns.
- ``residuals``, ``features``, ``pyramid``: what the algorithms compute on images.
- ``training/``: learning the update matrices, the cascade and the whole fitting model.
"""
