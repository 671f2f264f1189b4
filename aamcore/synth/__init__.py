"""Synthetic ground truth for head pose: a textured 3D head rendered under known poses.

- :mod:`aamcore.synth.head`: the MediaPipe mesh with exact iBUG-68 landmarks.
- :mod:`aamcore.synth.texture`: its texture, warped from an annotated photo.
- :mod:`aamcore.synth.renderer`: headless moderngl (EGL) rendering.
- :mod:`aamcore.synth.sequence`: pose sweeps, video and per-frame JSON.
"""

from aamcore.synth.head import SynthHead, synth_head
from aamcore.synth.sequence import (
    PoseTruth,
    exact_landmarks,
    load_sequence,
    render_sequence,
    sweep_poses,
    synthesize,
)

__all__ = [
    "PoseTruth",
    "SynthHead",
    "exact_landmarks",
    "load_sequence",
    "render_sequence",
    "sweep_poses",
    "synth_head",
    "synthesize",
]
