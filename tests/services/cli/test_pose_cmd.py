"""The ``aamtrack synth`` and ``aamtrack eval pose`` commands."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pytest

from services.cli import build_parser, main, pose_cmd


def test_eval_pose_json(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    plot = tmp_path / "pose.png"
    assert main(["eval", "pose", "--json", "--frames", "12", "--noise", "0,1",
                 "--plot", str(plot)]) == 0
    report = json.loads(capsys.readouterr().out)
    exact, noisy = report["posit_vs_sqpnp"]["noise"]
    assert exact["noise_px"] == 0.0 and exact["POSIT+GN"]["yaw"]["mae"] < 1e-4
    assert noisy["SQPNP"]["yaw"]["mae"] > 0.01
    assert report["sequence"]["frames"] == 12 and report["sequence"]["model"] == "openface_mean68"
    assert plot.is_file() and plot.stat().st_size > 10_000


def test_synth_then_eval_the_written_sequence(capsys: pytest.CaptureFixture[str],
                                              tmp_path: Path) -> None:
    out = tmp_path / "seq"
    assert main(["synth", "--out", str(out), "--frames", "4", "--sweep", "yaw",
                 "--width", "160", "--height", "120", "--max-angle", "60"]) == 0
    assert (out / "video.mp4").is_file() and len(list((out / "frames").glob("*.json"))) == 4
    assert json.loads((out / "sequence.json").read_text())["max_angle_deg"] == 60.0
    frame1 = json.loads((out / "frames" / "000001.json").read_text())
    assert frame1["rpy_deg"]["yaw"] == pytest.approx(60.0)
    capsys.readouterr()
    assert main(["eval", "pose", "--sequence", str(out), "--noise", "0", "--model", "exact"]) == 0
    text = capsys.readouterr().out
    assert "4/4 frames reliable" in text and "SQPNP" in text


def test_bad_arguments_give_clear_errors(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["eval", "pose", "--noise", "one"]) == 2
    assert "--noise must be comma-separated" in capsys.readouterr().err
    assert main(["eval", "pose", "--frames", "8", "--model", "nope"]) == 2
    assert "unknown model" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        build_parser().parse_args(["synth", "--out", "x", "--sweep", "spin"])


def test_joins_an_eval_group_made_by_another_module() -> None:
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command")
    other = sub.add_parser("eval").add_subparsers(dest="eval_command")
    other.add_parser("fit")
    pose_cmd.register(sub)
    assert parser.parse_args(["eval", "pose", "--frames", "3"]).frames == 3
    assert parser.parse_args(["eval", "fit"]).eval_command == "fit"
