"""Confusion matrices as text in the layout of tables 9.3-10.11 and as PNG heat maps."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from aamcore.evaluation.plots import new_figure
from aamcore.expression.evaluation import EvaluationResult
from aamcore.expression.labels import short_name

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def _cell(value: float) -> str:
    """A percentage as in the thesis tables: ``0``, ``100`` or two decimals."""
    if value == 0.0:
        return "0"
    text = f"{value:.2f}".rstrip("0").rstrip(".")
    return text


def format_confusion(result: EvaluationResult) -> str:
    """The confusion matrix as a tab-separated table with a caption and the overall rate.

    Rows are true classes, columns predicted classes, cells percentages of
    the row's class, then one line per class with its recognition rate.
    """
    names = [short_name(c) for c in result.class_names]
    percent = result.confusion_percent()
    lines = [
        f"{result.classifier} confusion matrix, {result.features} "
        "(rows: true class, columns: predicted, %)",
        "\t" + "\t".join(names),
    ]
    for name, row in zip(names, percent, strict=True):
        lines.append(name + "\t" + "\t".join(_cell(v) for v in row))
    lines.append(f"Overall recognition rate = {100 * result.overall_rate:.1f}%")
    rates = result.per_class_rates()
    lines.append(
        "Per class: " + ", ".join(f"{n} {100 * r:.1f}%" for n, r in zip(names, rates, strict=True))
    )
    return "\n".join(lines)


def confusion_figure(result: EvaluationResult) -> Figure:
    """A heat map of the row percentages with the value in every cell."""
    names = [short_name(c) for c in result.class_names]
    percent = result.confusion_percent()
    n = len(names)
    fig = new_figure(figsize=(1.0 + 0.8 * n, 1.0 + 0.75 * n), dpi=100)
    ax = fig.add_subplot()
    image = ax.imshow(percent, cmap="Blues", vmin=0.0, vmax=100.0)
    ax.set_xticks(np.arange(n), names)
    ax.set_yticks(np.arange(n), names)
    ax.set_xlabel("predicted")
    ax.set_ylabel("true class")
    for i in range(n):
        for j in range(n):
            colour = "white" if percent[i, j] > 60 else "black"
            ax.text(
                j,
                i,
                _cell(round(percent[i, j], 1)),
                ha="center",
                va="center",
                color=colour,
                fontsize=8,
            )
    ax.set_title(
        f"{result.classifier}, {result.features}\noverall {100 * result.overall_rate:.1f}%",
        fontsize=9,
    )
    fig.colorbar(image, ax=ax, fraction=0.046, pad=0.04, label="% of true class")
    fig.tight_layout()
    return fig


def save_confusion_png(result: EvaluationResult, path: str | Path) -> Path:
    """Write :func:`confusion_figure` to ``path`` (PNG); return the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    confusion_figure(result).savefig(path, format="png")
    return path
