"""The Active Appearance Model: Procrustes and PCA, shape, texture and combined models.

- ``pca``, ``procrustes``, ``similarity``: the building blocks.
- ``shape``, ``texture``, ``combined``: the three statistical models (thesis ch. 3-5).
- ``aam``: the trained model as one object; ``training`` builds it from annotated faces.
- ``file``: one file per model; ``cache``: models trained on first use and kept.
- ``visualise``: pictures of a model's modes and reconstructions.
"""
