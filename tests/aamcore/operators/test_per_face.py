"""aamcore.operators.per_face: one state per face id, the first kept for the one face at a
time, a face that missed a frame restarted, frames without a face face 0's."""

from __future__ import annotations

from aamcore.operators.per_face import FORGET_FRAMES, PerFace


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


def test_a_face_missing_from_a_frame_seen_restarts_whether_its_frames_come_whole_or_not(
        ) -> None:
    lost: list[int] = []
    for order in ("frame by frame", "face by face"):
        lost.clear()
        faces = PerFace(list, list.clear, lost=lambda state: lost.append(len(state)))
        seen = [(0, 0), (1, 0), (0, 1), (0, 2), (1, 2), (0, 3), (1, 3)]  # face 1 not on 1
        for face_id, frame in seen if order == "frame by frame" else sorted(
                seen, key=lambda s: (s[1], -s[0])):
            faces.of(face_id, frame).append(frame)
        assert lost == [1], order  # face 1 restarted once, when it came back on frame 2
    # a frame without a face (-1) is face 0's, and keeps it from missing a frame
    faces = PerFace(list, list.clear, lost=lambda state: lost.append(-1))
    first = faces.of(0, 0)
    assert faces.of(-1, 1) is first and faces.of(0, 2) is first and lost == [1]
