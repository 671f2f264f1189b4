"""Why a frame without a face may have none: it is too dark to find one.

Measured on the held-out faces of the expression sets (``python -m bench
expression-degraded``): at a quarter of their exposure (a mean grey level about 36) two faces
in three are still found, and read as well as at full exposure; at an eighth (about 18)
none is. A frame without a face under :data:`DARK_LEVEL` says so, so that a user in a dark
room is told to turn on a light rather than that there is nobody there.
"""

from __future__ import annotations

import numpy as np

DARK_LEVEL = 25.0
"""The mean grey level (of 255) under which a frame is too dark to find a face in."""


def darkness(image: np.ndarray) -> str:
    """Why ``image`` (H, W) or (H, W, C) uint8 is too dark to find a face in, or ``""``: its
    mean grey level (every eighth pixel of every eighth row: 30 us for a 640x360 frame
    without a face) under :data:`DARK_LEVEL`."""
    if np.ndim(image) < 2 or np.size(image) == 0:
        return ""
    seen = np.asarray(image)[::8, ::8]
    if seen.ndim == 3:
        seen = seen[:, :, :3]
    level = float(seen.sum(dtype=np.uint64)) / seen.size
    if level >= DARK_LEVEL:
        return ""
    return f"the frame is dark (mean grey level {level:.0f} of 255, at least {DARK_LEVEL:g} " \
           "to find a face)"
