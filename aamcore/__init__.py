"""aamcore: Active Appearance Model face tracking as a library, with no bus code.

The one-call API (loaded on first use, so that ``import aamcore`` stays light)::

    from aamcore import FaceTracker
    for result in FaceTracker().process_video("clip.mp4"):
        print(result.to_dict())

The stages, one package each (see ARCHITECTURE.md): ``io`` (datasets, images,
video, per-frame results), ``detection``, ``model``, ``warp``, ``fitting``,
``pose``, ``expression``, ``ar``, ``evaluation``, ``synth``; ``operators`` (each stage as
one operator, and the options tree, a part per stage), ``smoothing`` and ``tracker`` (the
API: the operators' chain) on top; ``defaults`` and ``config`` for settings.
"""

from __future__ import annotations

from typing import Any

__version__ = "0.2.0"
__all__ = ["FaceResult", "FaceTracker", "PipelineOptions"]


def __getattr__(name: str) -> Any:
    if name == "PipelineOptions":
        from aamcore.operators.options import PipelineOptions

        return PipelineOptions
    if name in __all__:
        from aamcore import tracker

        return getattr(tracker, name)
    raise AttributeError(f"module 'aamcore' has no attribute {name!r}")
