"""aamcore.results: per-frame CSV and JSON Lines read back with the standard library."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from aamcore.results import ResultWriter, columns
from aamcore.tracker import FaceResult


def results() -> list[FaceResult]:
    points = np.arange(136, dtype=float).reshape(68, 2)
    good = FaceResult(0, 0.0, True, 0.9, points, rotation=np.eye(3),
                      translation_mm=np.array([1.0, -2.0, 600.0]), roll_deg=1.0, pitch_deg=2.0,
                      yaw_deg=-3.0, pose_reliable=True, expression="HA",
                      expression_scores={"HA": 0.75, "NE": 0.25},
                      occluded=np.arange(68) >= 48)
    lost = FaceResult(1, 1 / 30, False, 0.0, np.zeros((0, 2)), reason="no face")
    return [good, lost]


def test_csv_rows_have_the_openface_like_columns(tmp_path: Path) -> None:
    path = tmp_path / "out.csv"
    with ResultWriter(path, "csv", 68, ("HA", "NE")) as writer:
        for r in results():
            writer.write(r)
    rows = list(csv.DictReader(path.open()))
    assert list(rows[0]) == columns(68, ("HA", "NE"))
    assert rows[0]["success"] == "1" and float(rows[0]["pose_Tz"]) == 600.0
    assert float(rows[0]["pose_yaw"]) == -3.0 and float(rows[0]["x_67"]) == 134.0
    assert float(rows[0]["y_0"]) == 1.0 and rows[0]["expression"] == "HA"
    assert float(rows[0]["score_HA"]) == 0.75
    assert rows[1]["success"] == "0" and rows[1]["pose_Tz"] == "" and rows[1]["x_0"] == ""
    assert rows[0]["pose_reliable"] == "1" and rows[0]["reason"] == ""
    assert rows[1]["pose_reliable"] == "" and rows[1]["reason"] == "no face"
    assert rows[0]["occluded_0"] == "0" and rows[0]["occluded_48"] == "1"
    assert rows[1]["occluded_48"] == ""


def test_json_lines_hold_one_result_each(tmp_path: Path) -> None:
    path = tmp_path / "out.jsonl"
    with ResultWriter(path, "jsonl", 68) as writer:
        for r in results():
            writer.write(r)
    lines = [json.loads(line) for line in path.read_text().splitlines()]
    assert [d["frame"] for d in lines] == [0, 1]
    assert lines[0]["translation_mm"] == [1.0, -2.0, 600.0] and lines[1]["reason"] == "no face"
    assert lines[0]["occluded"] == [False] * 48 + [True] * 20 and lines[1]["occluded"] is None
