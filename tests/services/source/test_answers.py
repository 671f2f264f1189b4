"""services.source.answers: a frame counts as answered once every stage of the run has done
with it; the slowest stage sets the pace."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from proto import Message
from proto.golden import golden_messages
from services.source.answers import Answers

GOLDEN = golden_messages()


def at(kind: str, index: int, **fields: object) -> Message:
    msg = GOLDEN[kind]
    return replace(msg, header=replace(msg.header, frame_index=index), **fields)


def fit(index: int, faces: int = 1, face: bool = True) -> Message:
    if face:
        return at("fit", index, faces=faces, face_id=0)
    return at("fit", index, faces=1, face_id=-1, landmarks=np.zeros((0, 2), np.float32),
              similarity=np.zeros(0, np.float32), appearance=None, warp_path="none",
              failed=True, failure_reason="no face", confidence=0.0)


def test_the_slowest_stage_holds_the_frame_until_it_has_answered() -> None:
    answers = Answers(["detector", "fitter", "pose", "expression", "ar"])
    assert answers.listens_to == ("fit", "pose", "expression", "overlay")
    assert answers.saw(fit(0)) == -1  # a pose, an expression and an overlay are owed
    assert answers.saw(at("pose", 0, reliable=True, reason="")) == -1
    assert answers.saw(at("expression", 0)) == -1
    assert answers.saw(at("overlay", 0)) == 0
    # A frame without a face owes its expression only.
    assert answers.saw(fit(1, face=False)) == 0
    assert answers.saw(at("expression", 1)) == 1
    # An unreliable pose owes no overlay.
    answers.saw(fit(2))
    answers.saw(at("expression", 2))
    assert answers.saw(at("pose", 2, reliable=False, reason="profile: yaw")) == 2


def test_every_face_of_a_frame_is_waited_for() -> None:
    answers = Answers(["pose"])
    answers.saw(fit(0, faces=2))
    assert answers.saw(at("pose", 0)) == -1  # the second face's fit has not come
    answers.saw(replace(fit(0, faces=2), face_id=1))
    assert answers.saw(replace(at("pose", 0), face_id=1)) == 0


def test_a_later_answer_of_a_stage_settles_what_it_owed_before() -> None:
    """Stages answer in frame order: an answer dropped on the way holds nothing up once a
    later one has come, results may come before their fit, and a frame whose fit never came
    is settled by the next frame's fit."""
    answers = Answers(["pose", "ar"])
    answers.saw(fit(0))
    answers.saw(at("pose", 0, reliable=True, reason=""))
    answers.saw(at("pose", 1, reliable=True, reason=""))  # before its fit
    answers.saw(fit(1))
    assert answers.answered == -1  # frame 0's overlay is owed
    assert answers.saw(at("overlay", 1)) == 1  # the renderer is past frame 0: settled
    answers.saw(fit(3))  # frame 2's fit never came
    answers.saw(at("pose", 3, reliable=False, reason="profile: yaw"))
    assert answers.answered == 3


def test_without_other_stages_a_frame_is_answered_by_its_fits() -> None:
    answers = Answers(["probe"])
    assert answers.listens_to == ("fit",)
    assert answers.saw(fit(0)) == 0 and answers.saw(fit(2)) == 2
    answers.skip_to(5)  # the credit window gave up on frames up to 5
    assert answers.saw(fit(4)) == 5 and answers.saw(fit(6)) == 6
