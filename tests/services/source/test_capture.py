"""services.source.capture: opening files, cameras and URLs with clear errors; looping."""

from __future__ import annotations

from pathlib import Path

import pytest

from services.source.capture import InputSpec, SourceError, VideoInput


def test_a_video_file_plays_every_frame_the_number_of_loops(single_face: Path) -> None:
    with VideoInput(InputSpec(video=str(single_face)), loops=2) as video:
        assert (video.width, video.height) == (640, 360) and video.fps == pytest.approx(30.0)
        frames = list(video.frames())
    assert len(frames) == 144
    assert all(f.shape == (360, 640, 3) for f in frames)
    assert (frames[0] == frames[72]).all() and not (frames[0] == frames[1]).all()


@pytest.mark.parametrize(
    ("content", "message"),
    [(None, "no such file"), (b"", "the file is empty"),
     (b"not a video at all\n" * 50, "OpenCV cannot open it")],
)
def test_bad_video_files_are_named_with_the_problem(
    tmp_path: Path, content: bytes | None, message: str
) -> None:
    path = tmp_path / "clip.mp4"
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(SourceError, match=message) as err:
        VideoInput(InputSpec(video=str(path)))
    assert str(path) in str(err.value)


def test_a_directory_is_not_a_video(tmp_path: Path) -> None:
    with pytest.raises(SourceError, match="is a folder, not a video file"):
        VideoInput(InputSpec(video=str(tmp_path)))


def test_an_absent_camera_is_a_clear_error() -> None:
    with pytest.raises(SourceError, match="camera 97"):
        VideoInput(InputSpec(camera=97))


def test_input_spec_needs_exactly_one_input_and_a_known_url_scheme() -> None:
    with pytest.raises(ValueError, match="exactly one"):
        InputSpec()
    with pytest.raises(ValueError, match="exactly one"):
        InputSpec(video="a.mp4", camera=0)
    with pytest.raises(ValueError, match="does not start with"):
        InputSpec(url="ftp://host/stream")
