"""The ``aamtrack eval expression`` command."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from aamcore.evaluation.expression_variants import JAFFE_ONLY
from services.cli import build_parser, main


def test_eval_expression_json(
    capsys: pytest.CaptureFixture[str], jaffe_dir: Path, model_path: Path, tmp_path: Path
) -> None:
    data = tmp_path / "jaffe3"  # three posers keep the run short
    data.mkdir()
    for poser in ("KA", "KL", "KM"):
        for image in jaffe_dir.glob(f"{poser}.*.tiff"):
            shutil.copy(image, data / image.name)
    out = tmp_path / "out"
    argv = ["eval", "expression", "--json", "--only", "JAFFE only", "--only", "SVM OvA (thesis)",
            "--classes", "5", "--trials", "2", "--grid", "coarse", "--data", str(data),
            "--fit-model", str(model_path), "--out", str(out)]
    code = main(argv)
    report = json.loads(capsys.readouterr().out)
    assert code == 0  # the targets are the bench's (bench/bench_expression.py)
    assert report["n_faces"] == 67 and report["model"] == model_path.name
    rows = report["rows"]
    assert set(rows) == {JAFFE_ONLY.name, "c, absolute, SVM OvA (thesis)"}
    five = sum(image.name[3:5] not in ("SA", "AN") for image in data.iterdir())
    assert all(r["5"]["n_samples"] == five for r in rows.values())  # every face of 5 classes
    assert rows[JAFFE_ONLY.name]["5"]["overall_rate"] > 0.5
    assert (out / "results.json").is_file() and len(list(out.glob("*.png"))) == 2


@pytest.mark.parametrize(("option", "value"), [("--classes", "6"), ("--grid", "fine"),
                                               ("--features", "pixels")])
def test_bad_options_are_refused(option: str, value: str) -> None:
    with pytest.raises(SystemExit):
        build_parser().parse_args(["eval", "expression", option, value])


def test_options_are_parsed_and_unknown_rows_refused(capsys: pytest.CaptureFixture[str]
                                                     ) -> None:
    parser = build_parser()
    args = parser.parse_args(["eval", "expression", "--only", "hog", "--classes", "7"])
    assert args.only == ["hog"] and args.classes == [7] and args.grid == "full"
    assert args.func.__module__ == "services.cli.expression_cmd"
    assert main(["eval", "expression", "--only", "lbp"]) == 2
    assert "no variant matches ['lbp']" in capsys.readouterr().err
