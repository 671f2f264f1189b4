"""Piecewise-affine warps between images and the model's reference frame.

- ``reference_frame``: the mean shape, its triangles and its pixels.
- ``piecewise_affine``: the CPU warp (``cv2.remap`` over precomputed weights).
- ``gl``: the same warp done by OpenGL; ``worker``: a thread that owns the GL
  context and warps for the fitting thread, with the CPU warp as fallback.
"""
