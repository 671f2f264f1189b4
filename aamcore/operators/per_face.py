"""One state per face id (landmark smoothing, a pose tracker, an expression recogniser), kept
by one rule in every operator (:mod:`aamcore.operators`), and so in the library and the
services alike.

- A frame without a tracked face (its one entry has ``face_id`` -1) is face 0's: the first
  face hears of it (its pose and smoothing restart, its expression hears of no face).
- A face missing from a frame the operator saw restarts what follows it from frame to frame
  when it comes back (``lost``: its smoothing, its pose), whether its frames come to the
  operator together (the library) or one message at a time (a service).
- A face not seen for :attr:`~aamcore.fitting.config.NewFaces.forget_frames` frames is
  forgotten, as its id can no longer be regained.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Generic, TypeVar

from aamcore.fitting.config import NewFaces

T = TypeVar("T")

FORGET_FRAMES = NewFaces().forget_frames
"""Frames after which a face not seen is forgotten by default: as long as its id can be
regained."""


class PerFace(Generic[T]):
    """The state of each face id.

    The first state, made up front, serves the first face that needs one while no other
    face holds it (with one face at a time, always the same one); any other face gets a
    new one. A face not seen for ``forget_frames`` frames (or seen on a later frame than
    this one: the source went back) is forgotten.

    Parameters
    ----------
    make : callable
        A fresh state.
    reset : callable
        Starts a state afresh (the first one, when a new face takes it over).
    first : optional
        The first state (made by ``make`` if not given).
    forget_frames : int
        :attr:`NewFaces.forget_frames <aamcore.fitting.config.NewFaces.forget_frames>` of
        the tracker whose faces these are.
    lost : callable, optional
        What a face's state does when it comes back after missing a frame (nothing if
        None).
    """

    def __init__(self, make: Callable[[], T], reset: Callable[[T], None],
                 first: T | None = None, forget_frames: int = FORGET_FRAMES,
                 lost: Callable[[T], None] | None = None) -> None:
        self.make = make
        self.reset = reset
        self.lost = lost
        self.forget_frames = forget_frames
        self.first = make() if first is None else first
        self._faces: dict[int, tuple[T, int]] = {}
        self._frame = self._before = -1

    def of(self, face_id: int, frame_index: int) -> T:
        """The state of face ``face_id`` (-1: face 0) seen on frame ``frame_index``."""
        face_id = max(face_id, 0)
        if frame_index != self._frame:
            self._before, self._frame = self._frame, frame_index
        self._faces = {k: v for k, v in self._faces.items()
                       if 0 <= frame_index - v[1] <= self.forget_frames}
        known = self._faces.get(face_id)
        if known is None:
            if any(state is self.first for state, _ in self._faces.values()):
                state = self.make()
            else:
                state = self.first
                self.reset(state)
        else:
            state = known[0]
            if known[1] < self._before and self.lost is not None:
                self.lost(state)  # missing from the frame seen before this one
        self._faces[face_id] = (state, frame_index)
        return state

    def known(self, face_id: int) -> T | None:
        """The state of face ``face_id`` if it is remembered, without seeing it."""
        known = self._faces.get(face_id)
        return None if known is None else known[0]

    def ids(self) -> list[int]:
        """The faces remembered."""
        return list(self._faces)

    def states(self) -> list[T]:
        """Every face's state."""
        return [state for state, _ in self._faces.values()]

    def clear(self) -> None:
        """Forget every face (a new run); the first state starts afresh."""
        self._faces.clear()
        self._frame = self._before = -1
        self.reset(self.first)
