"""aamcore.per_face: one state per face id, the first kept for the one face at a time."""

from __future__ import annotations

from aamcore.per_face import FORGET_FRAMES, PerFace


def test_each_face_has_its_state_and_the_first_serves_one_face_at_a_time() -> None:
    made: list[list[str]] = []
    resets: list[int] = []

    def make() -> list[str]:
        made.append([])
        return made[-1]

    faces = PerFace(make, lambda state: resets.append(id(state)))
    first = faces.first
    assert faces.of(0, 0) is first and faces.of(0, 1) is first
    other = faces.of(4, 1)
    assert other is not first and faces.of(4, 2) is other and len(made) == 2
    # face 0 unseen for longer than the window: forgotten; the next new face takes the first
    faces.of(4, 2 + FORGET_FRAMES)
    assert faces.of(7, 2 + FORGET_FRAMES) is first and resets.count(id(first)) == 2
    faces.clear()
    assert faces.states() == []
    # a source that went back forgets the faces seen later
    faces.of(1, 50)
    assert faces.of(2, 10) is first and faces.of(1, 10) is not first
