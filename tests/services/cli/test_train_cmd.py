import subprocess
import sys

import cv2

from services.cli import main


def test_train_show_modes_reconstruct(tmp_path, imm_dir, capsys) -> None:
    model = tmp_path / "imm.npz"
    assert (
        main(
            [
                "train",
                "--data",
                str(imm_dir),
                "--out",
                str(model),
                "--pixels",
                "2500",
                "--limit",
                "40",
                "--grey",
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "shape" in out and "combined" in out and "40 images" in out
    assert main(["model", "show", str(model)]) == 0
    assert "grey" in capsys.readouterr().out
    png = tmp_path / "modes.png"
    assert main(["model", "modes", str(model), "--out", str(png), "--modes", "2"]) == 0
    figure = cv2.imread(str(png))
    assert figure is not None and figure.shape[0] > figure.shape[1]
    rec = tmp_path / "rec.png"
    assert (
        main(
            [
                "model",
                "reconstruct",
                str(model),
                str(imm_dir / "11_02.jpg"),
                str(imm_dir / "11_02.asf"),
                "--out",
                str(rec),
            ]
        )
        == 0
    )
    image = cv2.imread(str(rec))
    assert image.shape == (600, 1600, 3)


def test_errors_are_clear(tmp_path, capsys) -> None:
    assert main(["train", "--data", "no_such_dataset"]) == 2
    assert "no_such_dataset" in capsys.readouterr().err
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"garbage")
    assert main(["model", "show", str(bad)]) == 2
    assert "not a model file" in capsys.readouterr().err


def test_console_script_runs() -> None:
    result = subprocess.run(
        [sys.executable, "-m", "services", "--help"], capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 0 and "train" in result.stdout
