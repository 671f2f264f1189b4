"""aamcore.evaluation.expression_report: confusion matrices (thesis layout) and the table."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from aamcore.evaluation.expression_report import format_confusion, save_confusion_png
from aamcore.evaluation.expression_results import NOT_CLASSIFIED, EvaluationResult
from aamcore.expression.labels import FIVE_CLASSES


def _result() -> EvaluationResult:
    y_true = np.repeat(np.array(FIVE_CLASSES), 4)
    y_pred = y_true.copy()
    y_pred[0] = "FE"  # one neutral taken for fear
    y_pred[5] = "DI"  # one happiness taken for disgust
    return EvaluationResult(
        "SVM DAG", "hog, relative", FIVE_CLASSES, y_true, y_pred, np.array(["KA"] * 20)
    )


def test_text_table_has_the_thesis_layout() -> None:
    lines = format_confusion(_result()).splitlines()
    assert "SVM DAG" in lines[0] and "hog, relative" in lines[0]
    assert lines[1].split("\t") == ["", "Neut", "Happ", "Surp", "Fear", "Disg"]
    assert lines[2].split("\t") == ["Neut", "75", "0", "0", "25", "0"]
    assert lines[3].split("\t") == ["Happ", "0", "75", "0", "0", "25"]
    assert lines[4].split("\t") == ["Surp", "0", "0", "100", "0", "0"]
    assert lines[7] == "Overall recognition rate = 90.0% of 20"
    assert lines[8].startswith("Per class: Neut 75.0%, Happ 75.0%, Surp 100.0%")


def test_png_heat_map_is_written(tmp_path: Path) -> None:
    path = save_confusion_png(_result(), tmp_path / "sub" / "confusion.png")
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    assert len(data) > 5000


def test_refused_faces_have_their_column(tmp_path: Path) -> None:
    result = _result()
    result.y_pred[1] = NOT_CLASSIFIED
    lines = format_confusion(result).splitlines()
    assert lines[1].split("\t")[-1] == "--"
    assert lines[2].split("\t") == ["Neut", "50", "0", "0", "25", "0", "25"]
    assert save_confusion_png(result, tmp_path / "c.png").is_file()
