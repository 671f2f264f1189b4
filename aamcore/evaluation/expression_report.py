"""The benchmark's table, confusion matrices as text in the layout of tables 9.3-10.11, and
as PNG heat maps."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from aamcore.evaluation.expression_lopo import ExpressionBenchmark
from aamcore.evaluation.expression_results import EvaluationResult
from aamcore.evaluation.expression_variants import JAFFE_ONLY
from aamcore.evaluation.plots import new_figure
from aamcore.expression.labels import short_name

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def _cell(value: float) -> str:
    """A percentage as in the thesis tables: ``0``, ``100`` or two decimals."""
    if value == 0.0:
        return "0"
    return f"{value:.2f}".rstrip("0").rstrip(".")


def format_confusion(result: EvaluationResult) -> str:
    """The confusion matrix as a tab-separated table with a caption and the overall rate.

    Rows are true classes, columns predicted classes (and ``--``, refused,
    when a face was), cells percentages of the row's class, then one line
    per class with its recognition rate.
    """
    names = [short_name(c) for c in result.class_names]
    columns = [short_name(c) for c in result.columns]
    lines = [
        f"{result.classifier} confusion matrix, {result.features} "
        "(rows: true class, columns: predicted, %)",
        "\t" + "\t".join(columns),
    ]
    for name, row in zip(names, result.confusion_percent(), strict=True):
        lines.append(name + "\t" + "\t".join(_cell(v) for v in row))
    lines.append(f"Overall recognition rate = {100 * result.overall_rate:.1f}% of {result.n}")
    rates = result.per_class_rates()
    lines.append(
        "Per class: " + ", ".join(f"{n} {100 * r:.1f}%" for n, r in zip(names, rates, strict=True))
    )
    return "\n".join(lines)


def confusion_figure(result: EvaluationResult) -> Figure:
    """A heat map of the row percentages with the value in every cell."""
    rows = [short_name(c) for c in result.class_names]
    columns = [short_name(c) for c in result.columns]
    percent = result.confusion_percent()
    fig = new_figure(figsize=(1.0 + 0.8 * len(columns), 1.0 + 0.75 * len(rows)), dpi=100)
    ax = fig.add_subplot()
    image = ax.imshow(percent, cmap="Blues", vmin=0.0, vmax=100.0)
    ax.set_xticks(np.arange(len(columns)), columns)
    ax.set_yticks(np.arange(len(rows)), rows)
    ax.set_xlabel("predicted")
    ax.set_ylabel("true class")
    for (i, j), value in np.ndenumerate(percent):
        ax.text(j, i, _cell(round(value, 1)), ha="center", va="center", fontsize=8,
                color="white" if value > 60 else "black")
    ax.set_title(f"{result.classifier}\noverall {100 * result.overall_rate:.1f}%", fontsize=9)
    fig.colorbar(image, ax=ax, fraction=0.046, pad=0.04, label="% of true class")
    fig.tight_layout()
    return fig


def save_confusion_png(result: EvaluationResult, path: str | Path) -> Path:
    """Write :func:`confusion_figure` to ``path`` (PNG); return the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    confusion_figure(result).savefig(path, format="png")
    return path


def format_benchmark(bench: ExpressionBenchmark) -> str:
    """The rows' table and the confusion matrices of the deployed pipeline before."""
    counts = sorted({n for by_n in bench.results.values() for n in by_n}, reverse=True)
    lines = [
        f"Expression recognition on JAFFE as the stack sees it (model {bench.model}): "
        f"leave-one-poser-out over all {bench.n_faces} faces",
        f"fits the fitter's own test rejected: {bench.n_fit_failed} (classified when the "
        f"expression gate accepts them); faces not found: {bench.n_no_face}",
        "",
        f"{'row':58} " + "  ".join(f"{n} classes (n, refused)" for n in counts),
    ]
    for name, by_n in bench.results.items():
        cells = [f"{100 * by_n[n].overall_rate:6.1f}% ({by_n[n].n:3d}, {len(by_n[n].refused):2d})"
                 if n in by_n else f"{'':20}" for n in counts]
        lines.append(f"{name:58} " + "    ".join(cells))
    for result in bench.results.get(JAFFE_ONLY.name, {}).values():
        lines += ["", format_confusion(result)]
    refused = sorted({f for by_n in bench.results.values() for r in by_n.values()
                      for f in r.refused})
    if refused:
        lines += ["", f"refused (counted wrong): {'; '.join(refused)}"]
    return "\n".join(lines)


def _slug(text: str) -> str:
    return "".join(ch if ch.isalnum() else "_" for ch in text).strip("_").lower()


def write_outputs(bench: ExpressionBenchmark, out_dir: str | Path) -> None:
    """Write ``results.json``, ``confusions.txt`` and one PNG per row and class count."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "results.json").write_text(json.dumps(bench.to_dict(), indent=1))
    texts = []
    for name, by_n in bench.results.items():
        for n, result in by_n.items():
            texts.append(format_confusion(result))
            save_confusion_png(result, out_dir / f"confusion_{n}classes_{_slug(name)}.png")
    (out_dir / "confusions.txt").write_text("\n\n".join(texts) + "\n")


def format_table(title: str, rows: dict[str, EvaluationResult], notes: list[str]) -> str:
    """A markdown table of rows: faces, share labelled, accuracy of the labelled faces, the
    mean of the classes' recalls and each class's (right of labelled), then the notes."""
    classes = next(iter(rows.values())).class_names if rows else ()
    lines = [title, "",
             "| row | faces | labelled % | right of labelled % | mean recall | "
             + " | ".join(short_name(c) for c in classes) + " |",
             "|---" * (5 + len(classes)) + "|"]
    for name, r in rows.items():
        recalls = r.recalls()
        cells = [f"{k}/{n}" if n else "-" for k, n in (recalls[c] for c in classes)]
        lines.append(f"| {name} | {r.n} | {100 * r.share_labelled:.1f} | "
                     f"{100 * r.labelled_accuracy:.1f} | {r.mean_recall:.3f} | "
                     + " | ".join(cells) + " |")
    return "\n".join(lines + [f"  {note}" for note in notes])
