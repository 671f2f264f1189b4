"""The pipeline's stages as operators, one module each: each owns its per-face state and maps
a frame's inputs to its outputs for any number of faces, in one process
(:class:`aamcore.tracker.FaceTracker` chains them) or one stage a process (each service of
``services/`` is a thin adapter around one), as dora's operators and nodes.

- :mod:`~aamcore.operators.options`: the options tree, a part per stage (light to import);
- :mod:`~aamcore.operators.faces`: what passes between the stages (:class:`FrameRef`,
  :class:`FaceFit`, :class:`FacePose`);
- :mod:`~aamcore.operators.detect`, :mod:`~aamcore.operators.fit`,
  :mod:`~aamcore.operators.pose`, :mod:`~aamcore.operators.expression`,
  :mod:`~aamcore.operators.overlay`: the stages.

Nothing is imported here: option parsers load :mod:`~aamcore.operators.options` alone.
"""
