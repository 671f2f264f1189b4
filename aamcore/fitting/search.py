"""When a tracker without a face searches for one, so that frames without a face stay cheap.

A Haar pass costs about 10 ms a frame at the detector's default size (more than a
third of a 30 fps frame period on one core), and a pass in the turned frame as much
again plus the rotation. Right after a face is lost it is most likely to come back, so
every frame is searched both ways; after that the passes are spread over the frames, so
that a camera on an empty room or a video between shots keeps up with real time.
"""

from __future__ import annotations

from dataclasses import dataclass

from aamcore.settings import Settings, setting


@dataclass(frozen=True)
class SearchSchedule(Settings):
    """Which Haar passes the ``k``-th frame in a row without a face gets.

    Attributes
    ----------
    eager : int
        Frames after a loss (or from the start) searched both upright and turned.
    upright_every : int
        Then every this many frames upright: a face that appears is fitted within as many
        frames.
    turned_every : int
        And every this many frames in the frame turned by the last roll (or +-25 degrees
        in turn), on other frames than the upright passes where they can: a rolled face
        that comes back is found within as many frames.
    """

    eager: int = setting(3, "frames after a face is lost searched both upright and turned",
                         low=0, metavar="N")
    upright_every: int = setting(3, "then search upright every N frames without a face",
                                 low=1, metavar="N")
    turned_every: int = setting(5, "and in the frame turned by the last roll every N frames",
                                low=1, metavar="N")

    @classmethod
    def every_frame(cls) -> SearchSchedule:
        """Both passes on every frame without a face (offline work, where time is no object)."""
        return cls(eager=0, upright_every=1, turned_every=1)

    def passes(self, k: int) -> tuple[bool, bool]:
        """Whether frame ``k`` (0: the frame the face was lost on) is searched upright and
        whether in the turned frame."""
        if k < self.eager:
            return True, True
        j = k - self.eager
        return j % self.upright_every == 0, j % self.turned_every == self.turned_every - 1
