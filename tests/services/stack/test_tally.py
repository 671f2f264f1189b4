"""services.stack.tally: answers per frame counted in bounded memory; closing at a restart
makes later answers for earlier frames late, never answers."""

from __future__ import annotations

from services.stack.tally import Pairs, Tally


def test_distinct_frames_are_counted_once_in_a_window_however_long_the_run() -> None:
    tally = Tally(window=64)
    for index in [*range(10_000), 5, 9_999]:
        tally.add(index)
    assert tally.count == 10_000 and tally.late == 1  # 5 is long gone: late; 9999 a repeat
    assert len(tally._recent) <= 64 and len(tally._order) <= 64
    assert 9_999 in tally and tally.highest == 9_999


def test_closing_at_a_restart_makes_later_answers_to_earlier_frames_late() -> None:
    tally = Tally()
    for index in (0, 1, 2):
        tally.add(index)
    tally.close(9)  # the fitter restarted when the run had reached frame 9
    assert not tally.add(5) and not tally.add(9) and tally.add(10)
    assert (tally.count, tally.late) == (4, 2)


def test_fits_and_their_poses_are_matched_in_bounded_memory() -> None:
    pairs = Pairs(window=32)
    for index in range(5_000):
        pairs.fit((index, 0))
        if index % 10:  # every tenth fit gets no pose
            pairs.pose((index, 0))
    pairs.pose((6_000, 0))  # a pose before its fit
    pairs.fit((6_000, 0))
    assert (pairs.with_face, pairs.posed) == (5_001, 4_501)
    assert len(pairs._owed) <= 32 and len(pairs._early) <= 32
    pairs.close(7_000)
    pairs.fit((6_500, 0))
    pairs.pose((6_500, 0))  # its pose after the pose service's restart: late
    assert (pairs.posed, pairs.late) == (4_501, 1)
