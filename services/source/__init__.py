"""The frame source service: video files, cameras and stream URLs onto the bus.

- :mod:`services.source.capture`: opening a video input with clear errors.
- :mod:`services.source.pacing`: real-time pacing and the in-flight window.
- :mod:`services.source.service`: the process (``main``).
"""
