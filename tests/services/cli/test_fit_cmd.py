import json

import cv2

from services.cli import main


def test_fit_writes_landmarks_and_drawing(imm_fit_model_path, imm_test, tmp_path, capsys) -> None:
    images = [str(imm_test[0].image_path), str(imm_test[5].image_path)]
    out = tmp_path / "fits.json"
    assert (
        main(
            [
                "fit",
                *images,
                "--model",
                str(imm_fit_model_path),
                "--draw",
                str(tmp_path),
                "--out",
                str(out),
            ]
        )
        == 0
    )
    fits = json.loads(out.read_text())
    assert [f["face"] for f in fits] == [True, True]
    assert len(fits[0]["landmarks"]) == 73
    drawn = cv2.imread(str(tmp_path / f"{imm_test[0].image_path.stem}_fit.png"))
    assert drawn is not None and drawn.shape == (600, 800, 3)


def test_fit_reports_no_face(imm_fit_model_path, tmp_path, capsys) -> None:
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), 128 * __import__("numpy").ones((300, 400, 3), "uint8"))
    assert main(["fit", str(blank), "--model", str(imm_fit_model_path)]) == 0
    assert json.loads(capsys.readouterr().out) == [{"image": str(blank), "face": False}]


def test_eval_landmarks_json(imm_fit_model_path, imm_dir, tmp_path, capsys) -> None:
    ced = tmp_path / "ced.png"
    assert (
        main(
            [
                "eval",
                "landmarks",
                "--model",
                str(imm_fit_model_path),
                "--data",
                str(imm_dir),
                "--limit",
                "6",
                "--json",
                "--ced",
                str(ced),
            ]
        )
        == 0
    )
    result = json.loads(capsys.readouterr().out)
    assert result["images"] == 6 and result["mean"] < 0.08
    assert {"median", "failure_008", "failure_010", "mean_seconds"} <= set(result)
    assert cv2.imread(str(ced)) is not None


def test_eval_fit_table(imm_fit_model_path, imm_dir, capsys) -> None:
    assert (
        main(
            [
                "eval",
                "fit",
                "--model",
                str(imm_fit_model_path),
                "--data",
                str(imm_dir),
                "--limit",
                "2",
                "--offsets=-20,0,20",
                "--algorithm",
                "fixed-jacobian",
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "failure rate, cog start" in out and "failure rate, haar start" in out


def test_eval_refuses_training_images(imm_fit_model_path, tmp_path, imm_train, capsys) -> None:
    import shutil

    for s in imm_train[:3]:
        shutil.copy(s.image_path, tmp_path)
        shutil.copy(s.image_path.with_suffix(".asf"), tmp_path)
    assert (
        main(["eval", "landmarks", "--model", str(imm_fit_model_path), "--data", str(tmp_path)])
        == 2
    )
    assert "used to train" in capsys.readouterr().err
