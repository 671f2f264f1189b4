"""One state per face of a run's fits (a service's smoothing, pose tracker or expression
recogniser), as the library keeps one per face (:class:`aamcore.tracker.FaceTracker`)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Generic, TypeVar

T = TypeVar("T")

FORGET_FRAMES = 90
"""Frames after which a face not seen is forgotten (as long as its id can be regained,
``aamcore.fitting.multi.NewFaces.hidden_frames``)."""


class PerFace(Generic[T]):
    """The state of each face id.

    The first state, made up front, serves the first face that needs one while no other
    face holds it (with one face at a time, always the same one); any other face gets a
    new one. A face not seen for :data:`FORGET_FRAMES` frames (or seen on a later frame
    than this one: the source went back) is forgotten.

    Parameters
    ----------
    make : callable
        A fresh state.
    reset : callable
        Starts a state afresh (the first one, when a new face takes it over).
    first : optional
        The first state (made by ``make`` if not given).
    """

    def __init__(self, make: Callable[[], T], reset: Callable[[T], None],
                 first: T | None = None) -> None:
        self.make = make
        self.reset = reset
        self.first = make() if first is None else first
        self._faces: dict[int, tuple[T, int]] = {}

    def of(self, face_id: int, frame_index: int) -> T:
        """The state of face ``face_id``, seen on frame ``frame_index``."""
        self._faces = {k: v for k, v in self._faces.items()
                       if 0 <= frame_index - v[1] <= FORGET_FRAMES}
        known = self._faces.get(face_id)
        if known is None:
            if any(state is self.first for state, _ in self._faces.values()):
                state = self.make()
            else:
                state = self.first
                self.reset(state)
        else:
            state = known[0]
        self._faces[face_id] = (state, frame_index)
        return state

    def states(self) -> list[T]:
        """Every face's state."""
        return [state for state, _ in self._faces.values()]

    def clear(self) -> None:
        """Forget every face (a new run)."""
        self._faces.clear()
