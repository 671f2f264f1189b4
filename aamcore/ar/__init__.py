"""Augmented reality (thesis chapter 15): virtual glasses drawn on the tracked head.

- :mod:`aamcore.ar.mesh_primitives`: triangle meshes (tubes, fans, ellipsoids).
- :mod:`aamcore.ar.glasses_mesh`: the glasses model, placed on the mean head.
- :mod:`aamcore.ar.head_occluder`: the head surface that hides what is behind it.
- :mod:`aamcore.ar.projection`: OpenCV intrinsics and pose as OpenGL matrices.
- :mod:`aamcore.ar.renderer`: the OpenGL renderer that composites glasses on a frame.
"""
