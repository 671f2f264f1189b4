"""The glasses AR service: 3D glasses drawn at each head pose (:mod:`services.ar.service`)."""
