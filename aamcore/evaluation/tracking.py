"""Running a tracker over a sequence of frames, for end-to-end evaluations."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from aamcore.fitting.tracker import Tracker


def track_frames(
    frames: Iterable[np.ndarray], tracker: Tracker
) -> tuple[list[np.ndarray | None], int]:
    """Track every frame; landmarks (N, 2) per frame, None where there was no good fit.

    Returns
    -------
    landmarks : list
    flagged : int
        Fits left out because they failed the tracker's failure test.
    """
    tracker.reset()
    landmarks: list[np.ndarray | None] = []
    flagged = 0
    for frame in frames:
        fit = tracker.track(frame)
        if fit is not None and fit.failed:
            flagged += 1
        landmarks.append(None if fit is None or fit.failed else fit.points)
    return landmarks, flagged
