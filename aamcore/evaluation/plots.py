"""PNG figures of fit errors: CED curves and the thesis's displacement plots.

Figures are drawn on matplotlib's Agg canvas directly, so importing this
module neither needs a display nor changes the global pyplot backend.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from aamcore.evaluation.metrics import ced

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def new_figure(**kwargs: Any) -> Figure:
    """A matplotlib figure on the Agg canvas.

    Raises
    ------
    ImportError
        Saying how to install the plotting extra when matplotlib is missing.
    """
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as exc:
        raise ImportError("PNG figures need matplotlib: pip install 'aamtrack[plots]'") from exc
    fig = Figure(**kwargs)
    FigureCanvasAgg(fig)
    return fig


def _save(fig: Figure, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    return path


def _row_mean_std(arr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and std of each row of a (D, R) array over its finite entries (NaN if none)."""
    finite = np.isfinite(arr)
    count = finite.sum(axis=1)
    mean = np.divide(
        np.where(finite, arr, 0.0).sum(axis=1),
        count,
        out=np.full(len(arr), np.nan),
        where=count > 0,
    )
    sq = np.where(finite, (arr - mean[:, None]) ** 2, 0.0).sum(axis=1)
    std = np.sqrt(np.divide(sq, count, out=np.full(len(arr), np.nan), where=count > 0))
    return mean, std


def save_ced_png(
    curves: Mapping[str, Sequence[float] | np.ndarray],
    path: str | Path,
    max_error: float = 0.15,
    n_steps: int = 301,
    xlabel: str = "NME (outer-eye-corner normalised)",
    title: str | None = None,
) -> Path:
    """Plot cumulative error distributions, one curve per entry, to a PNG.

    Parameters
    ----------
    curves : mapping of str to (M,) errors
        Label -> per-image errors (NaN for a missing fit).
    path : path
        Output PNG; parent folders are created.
    max_error : float
        Right end of the error axis.
    n_steps : int
        Thresholds sampled between 0 and ``max_error``.
    xlabel, title : str
        Axis label and optional title.

    Returns
    -------
    Path
        The written file.
    """
    if not curves:
        raise ValueError("no curves to plot")
    if not max_error > 0:
        raise ValueError(f"max_error must be > 0, got {max_error}")
    thresholds = np.linspace(0.0, max_error, n_steps)
    fig = new_figure(figsize=(6, 4.5))
    ax = fig.add_subplot()
    for label, errors in curves.items():
        ax.plot(thresholds, ced(errors, thresholds), label=f"{label} (n={len(errors)})")
    ax.set_xlim(0, max_error)
    ax.set_ylim(0, 1)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("fraction of images")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="lower right", fontsize="small")
    if title:
        ax.set_title(title)
    fig.tight_layout()
    return _save(fig, path)


def save_displacement_plot(
    offsets: Sequence[float] | np.ndarray,
    results: Mapping[str, Mapping[str, np.ndarray]],
    path: str | Path,
    xlabel: str = "start displacement (px)",
    title: str | None = None,
) -> Path:
    """Metric against start displacement, with unit standard-deviation bars.

    One panel per metric (thesis figures 7.7 and 7.8: point-to-point,
    point-to-border, average Procrustes, texture error), one line per series
    (e.g. displacement along ``x`` and along ``y``).

    Parameters
    ----------
    offsets : (D,) array
        Displacements in pixels.
    results : mapping of metric name to mapping of series name to (D, R) array
        ``results[metric][series][d, r]`` is the metric of trial ``r`` started
        at offset ``d``; NaN entries (failed trials) are left out of the
        mean and standard deviation.
    path : path
        Output PNG; parent folders are created.

    Returns
    -------
    Path
        The written file.
    """
    x = np.asarray(offsets, dtype=np.float64)
    if not results:
        raise ValueError("no metrics to plot")
    n = len(results)
    cols = min(n, 2)
    rows = (n + cols - 1) // cols
    fig = new_figure(figsize=(5.5 * cols, 4 * rows))
    for k, (metric, series) in enumerate(results.items()):
        ax = fig.add_subplot(rows, cols, k + 1)
        for name, values in series.items():
            mean, std = _row_mean_std(np.asarray(values, dtype=np.float64).reshape(len(x), -1))
            ax.errorbar(x, mean, yerr=std, capsize=3, marker="o", markersize=3, label=name)
        ax.set_title(metric)
        ax.set_xlabel(xlabel)
        ax.grid(True, alpha=0.3)
        ax.legend()
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return _save(fig, path)
