"""Rerun logging of an aamtrack stream: one logger per kind of output, a blueprint, a service.

- :mod:`~services.rerun_logger.loggers`: ``ImageLogger``, ``BoxesLogger``,
  ``FitLogger``, ``PoseLogger``, ``ExpressionLogger``, ``LatencyLogger``,
  ``StatusLogger``; each takes decoded proto messages and a
  ``rerun.RecordingStream``, no bus.
- :mod:`~services.rerun_logger.dispatch`: ``StreamLogger`` routes any message
  to its logger on the ``frame`` and ``capture_time`` timelines.
- :mod:`~services.rerun_logger.blueprint`: the viewer layout.
- :mod:`~services.rerun_logger.recording`: a headless recording to an ``.rrd``
  file, a gRPC server bound to 127.0.0.1 and/or a running viewer.
- :mod:`~services.rerun_logger.viewer`: viewer URLs, and the check that a
  viewer answers (no ``rerun`` import: the launcher's preflight uses it).
- :mod:`~services.rerun_logger.annotations`: landmark classes, one per
  facial part, and one for failed fits.
- :mod:`~services.rerun_logger.service`: ``main(argv)``, the Zenoh service.
- :mod:`~services.rerun_logger.entities`: entity paths and timelines.
"""
