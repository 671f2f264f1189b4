"""``aamtrack model prepare`` and ``model show`` on the real cached models."""

from __future__ import annotations

from pathlib import Path

from services.cli import main
from tests.conftest import MODEL_IMAGES, MODEL_LIMIT


def test_prepare_names_the_model_the_stack_uses(model_path: Path, capsys) -> None:
    code = main(["model", "prepare", "--limit", str(MODEL_LIMIT),
                 "--update-images", str(MODEL_IMAGES), "--no-classifier"])
    out = capsys.readouterr().out
    assert code == 0
    assert out.strip() == f"fitting model {model_path}"


def test_show_prints_modes_and_training_facts(model_path: Path, capsys) -> None:
    assert main(["model", "show", str(model_path)]) == 0
    out = capsys.readouterr().out
    assert "scheme ibug68 (68 points)" in out
    assert "trained on" in out
    assert "fern stages + " in out and "restart stages" in out


def test_show_of_a_missing_file_is_a_clear_error(tmp_path: Path, capsys) -> None:
    assert main(["model", "show", str(tmp_path / "none.npz")]) == 2
    assert "none.npz" in capsys.readouterr().err
