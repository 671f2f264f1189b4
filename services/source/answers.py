"""Which frames the whole stack has answered: the credit of the source's fast pacing.

At ``--pace fast`` the source publishes a frame once the frames before it, but
``--window``, have been answered (:class:`services.source.pacing.CreditWindow`); a frame is
answered when every stage of the run has done with it, so that the slowest stage sets the
pace and none of them piles up frames:

- the fitter: the frame's fits (``fit.faces`` of them);
- the pose service: a pose per fit with landmarks;
- the expression service: an expression per fit;
- the glasses renderer: an overlay per reliable pose.

Each stage answers in frame order, so a later frame's answer from a stage also settles
what that stage owed an earlier one (an answer dropped on the way, a pose whose frame the
renderer no longer had).
"""

from __future__ import annotations

import threading
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field

from proto import Message

STAGE_KINDS = {"pose": "pose", "expression": "expression", "ar": "overlay"}
"""The kind each stage beyond the fitter answers with, by service name."""


@dataclass
class _Owed:
    faces: int = 0
    fits: int = 0
    owed: Counter[str] = field(default_factory=Counter)
    got: Counter[str] = field(default_factory=Counter)


class Answers:
    """What each frame in flight is owed by the run's stages, and the last frame answered.

    Parameters
    ----------
    services : iterable of str
        The services of the run beside the source; those of :data:`STAGE_KINDS` are waited
        for, the fitter always.
    """

    def __init__(self, services: Iterable[str]) -> None:
        self.kinds = tuple(STAGE_KINDS[s] for s in services if s in STAGE_KINDS)
        self.answered = -1
        self._frames: dict[int, _Owed] = {}
        self._latest = Counter({kind: -1 for kind in ("fit", *self.kinds)})
        self._lock = threading.Lock()

    @property
    def listens_to(self) -> tuple[str, ...]:
        """The kinds to subscribe to."""
        return ("fit", *self.kinds)

    def saw(self, msg: Message) -> int:
        """Take one result of the run; the last frame answered, all those before it too."""
        index = msg.header.frame_index
        with self._lock:
            if index <= self.answered:
                return self.answered
            frame = self._frames.setdefault(index, _Owed())
            kind = msg.KIND
            self._latest[kind] = max(self._latest[kind], index)
            if kind == "fit":
                frame.fits += 1
                frame.faces = msg.faces  # type: ignore[attr-defined]
                if "expression" in self.kinds:
                    frame.owed["expression"] += 1
                if "pose" in self.kinds and len(msg.landmarks):  # type: ignore[attr-defined]
                    frame.owed["pose"] += 1
            else:
                frame.got[kind] += 1
                reliable = getattr(msg, "reliable", False)
                if kind == "pose" and "overlay" in self.kinds and reliable:
                    frame.owed["overlay"] += 1
            self._advance()
            return self.answered

    def skip_to(self, index: int) -> None:
        """Give up on the frames up to ``index`` (the credit window timed out on them)."""
        with self._lock:
            if index > self.answered:
                self.answered = index
                self._advance()

    def _done(self, index: int) -> bool:
        frame = self._frames.get(index) or _Owed()
        # A later frame's fit settles this one's: those that did not come never will.
        fits_in = 0 < frame.fits >= frame.faces or self._latest["fit"] > index
        return fits_in and all(frame.got[k] >= frame.owed[k] or self._latest[k] > index
                               for k in self.kinds)

    def _advance(self) -> None:
        while self._done(self.answered + 1):
            self.answered += 1
        for old in [i for i in self._frames if i <= self.answered]:
            del self._frames[old]
