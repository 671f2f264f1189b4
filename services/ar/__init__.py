"""Augmented reality (thesis chapter 15): virtual glasses drawn on the tracked head.

- :mod:`services.ar.mesh_primitives`: triangle meshes (tubes, fans, ellipsoids).
- :mod:`services.ar.glasses_mesh`: the glasses model, placed on the mean head.
- :mod:`services.ar.head_occluder`: the head surface that hides what is behind it.
- :mod:`services.ar.projection`: OpenCV intrinsics and pose as OpenGL matrices.
- :mod:`services.ar.renderer`: the OpenGL renderer that composites glasses on a frame.
"""
