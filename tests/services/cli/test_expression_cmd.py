"""The ``aamtrack eval expression`` command."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from services.cli import build_parser, main


def test_eval_expression_json(
    capsys: pytest.CaptureFixture[str], jaffe_dir: Path, tmp_path: Path
) -> None:
    data = tmp_path / "jaffe3"  # three posers keep the run short
    data.mkdir()
    for poser in ("KA", "KL", "KM"):
        for image in jaffe_dir.glob(f"{poser}.*.tiff"):
            shutil.copy(image, data / image.name)
    out = tmp_path / "out"
    argv = [
        "eval",
        "expression",
        "--json",
        "--variances",
        "90",
        "--classes",
        "5",
        "--trials",
        "2",
        "--grid",
        "coarse",
        "--data",
        str(data),
        "--out",
        str(out),
        "--features",
        "pixels",
    ]
    code = main(argv)
    report = json.loads(capsys.readouterr().out)
    five = report["class_sets"]["5"]
    assert code == (0 if report["classify_passed"] and five["passed"] else 1)
    assert report["features"] == "pixel PCA baseline"
    assert five["best"]["variance"] == 0.9
    assert {r["classifier"] for r in five["runs"]} == {
        "LDA+Mahalanobis",
        "SVM OvA",
        "SVM OvO",
        "SVM DAG",
    }
    assert all(r["n_samples"] == 48 for r in five["runs"])
    assert (out / "results.json").is_file()
    assert len(list(out.glob("*.png"))) == 4


@pytest.mark.parametrize(
    ("option", "value"),
    [("--variances", "0"), ("--variances", "abc"), ("--classes", "6"), ("--features", "hog")],
)
def test_bad_options_are_refused(option: str, value: str) -> None:
    with pytest.raises(SystemExit):
        build_parser().parse_args(["eval", "expression", option, value])


def test_options_are_parsed() -> None:
    parser = build_parser()
    args = parser.parse_args(["eval", "expression", "--variances", "95,99.5", "--classes", "7"])
    assert args.variances == [0.95, 0.995] and args.classes == [7]
    assert args.func.__module__ == "services.cli.expression_cmd"


def test_eval_expression_on_aam_features(jaffe_dir, lfpw_fit_model_path, tmp_path, capsys) -> None:
    data = tmp_path / "jaffe"
    data.mkdir()
    for poser in ("KA", "KL", "KM"):
        for image in jaffe_dir.glob(f"{poser}.*.tiff"):
            shutil.copy(image, data / image.name)
    argv = [
        "eval",
        "expression",
        "--json",
        "--variances",
        "95",
        "--classes",
        "5",
        "--trials",
        "2",
        "--grid",
        "coarse",
        "--data",
        str(data),
        "--fit-model",
        str(lfpw_fit_model_path),
    ]
    main(argv)
    report = json.loads(capsys.readouterr().out)
    assert report["features"].startswith("AAM appearance")
    assert report["class_sets"]["5"]["best"]["overall_rate"] > 0.3
