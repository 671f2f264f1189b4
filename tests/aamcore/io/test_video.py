"""aamcore.io.video: what a video file states, and when it ended before it."""

from __future__ import annotations

from pathlib import Path

from aamcore.io.video import ended_early, ended_early_problem, video_facts
from tests.videos import decoded_frames, faststart


def test_an_intact_file_that_states_a_few_frames_more_has_not_ended_early(
    no_face: Path, single_face: Path, tmp_path: Path,
) -> None:
    # no_face.mp4 states 98 frames and decodes 95 (its edit list), its index at the front too
    for video in (no_face, single_face):
        front = tmp_path / video.name
        front.write_bytes(faststart(video.read_bytes()))
        for path in (video, front):
            stated, read = video_facts(path)[0], decoded_frames(path)
            assert read <= stated and not ended_early(read, stated), (path, read, stated)


def test_half_of_a_file_whose_index_is_at_the_front_has_ended_early(
    single_face: Path, tmp_path: Path,
) -> None:
    whole = faststart(single_face.read_bytes())
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(whole[: len(whole) // 2])
    stated, read = video_facts(cut)[0], decoded_frames(cut)
    assert stated == 72 and 10 < read < 72 and ended_early(read, stated)
    assert ended_early_problem(cut, read, stated) == (
        f"{cut}: the video ended after frame {read - 1} ({read} of its 72 frames: cut short "
        "or damaged?)")
    assert ended_early(96, 100) and not ended_early(97, 100)  # 3 frames, or 1 %, tolerated
    assert ended_early(980, 1000) and not ended_early(990, 1000)
    assert not ended_early(5, 0)  # a container that states no count
