"""aamcore: Active Appearance Models as a library, with no bus code.

Modules, one idea each:

- ``config``: where the data and the model cache live.
- ``landmarks``: landmark schemes (point count, drawing connectivity, groups).
- ``datasets``: readers for ``.asf`` (IMM) and ``.pts`` (300-W) annotations.
- ``procrustes`` and ``pca``: the shape-analysis building blocks.
- ``shape_model``, ``texture_model``, ``combined_model``: the three models.
- ``reference_frame`` and ``warp``: the piecewise-affine warp.
- ``aam``: the trained model as one object, with save and load in ``model_file``.
"""

__version__ = "0.1.0"
