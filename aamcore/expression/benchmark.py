"""The JAFFE expression benchmark behind ``bench/bench_expression.py`` and the CLI.

For every kept-variance fraction and for seven and five classes, runs
leave-one-poser-out with LDA+Mahalanobis and the three SVM schemes, names
the best, checks the recognition-rate targets, and times the classification
of one vector by a saved-and-reloaded :class:`ExpressionClassifier`.

The features are the AAM appearance vectors of :mod:`.aam_features`
(:func:`load_aam_data`) or, for comparison, the pixel PCA baseline of
:mod:`.features` (:func:`load_pixel_data`); outputs name which.
"""

from __future__ import annotations

import json
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from aamcore import defaults
from aamcore.expression.aam_features import AAMAppearanceFeatures, fit_faces
from aamcore.expression.classifier_file import ExpressionClassifier
from aamcore.expression.evaluation import (
    ClassifierSpec,
    EvaluationResult,
    FoldFeatures,
    default_classifiers,
    leave_one_poser_out,
    restrict_classes,
)
from aamcore.expression.features import BASELINE_NAME, PixelPCAFeatures, crop_faces
from aamcore.expression.labels import FIVE_CLASSES, SEVEN_CLASSES
from aamcore.expression.report import format_confusion, save_confusion_png
from aamcore.expression.svm import C_GRID, GAMMA_GRID
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.fitting.training.prepare import default_model_path
from aamcore.io.jaffe import load_jaffe

VARIANCES = defaults.EXPRESSION_VARIANCES
CLASS_SETS: dict[int, tuple[str, ...]] = {7: SEVEN_CLASSES, 5: FIVE_CLASSES}
RATE_TARGETS: dict[int, float] = {7: 0.65, 5: 0.80}
"""Overall leave-one-poser-out recognition rate targets."""
CLASSIFY_TARGET_MS = 1.0
"""Target time to classify one appearance vector."""
AAM_FEATURES_NAME = "AAM appearance c (LFPW-trained fitter, per-fold JAFFE AAM)"
BASELINE_FINGERPRINT = "pixel-pca-baseline"
"""Stands in for an AAM fingerprint in the classifiers timed on baseline features."""


@dataclass
class PixelData:
    """JAFFE faces with labels and posers, as the inputs of one feature extractor.

    Attributes
    ----------
    pixels : (n, p) float64 array or (n,) object array
        The extractor's inputs: face-crop pixels for the pixel baseline, or
        faces with fitted landmarks for the AAM features.
    labels, posers : (n,) str arrays
    skipped : list of str
        Files left out (unreadable, bad name, no face found, failed fit).
    make_features : callable
        ``make_features(variance) -> FoldFeatures``.
    features_name : str
    """

    pixels: np.ndarray
    labels: np.ndarray
    posers: np.ndarray
    skipped: list[str] = field(default_factory=list)
    make_features: Callable[[float], FoldFeatures] = PixelPCAFeatures
    features_name: str = BASELINE_NAME

    def subset(self, mask: np.ndarray) -> PixelData:
        """The samples selected by a boolean mask (n,)."""
        return replace(
            self, pixels=self.pixels[mask], labels=self.labels[mask], posers=self.posers[mask]
        )


def load_aam_data(folder: str | Path | None = None, fitter: Fitter | None = None) -> PixelData:
    """Read JAFFE and fit every face with the generic fitter (see :mod:`.aam_features`).

    The fitter defaults to the stack's model (:func:`fitting_model_path`),
    trained on the training splits of LFPW, HELEN and AFW.
    """
    jaffe = load_jaffe(folder)
    fitter = fitter or Fitter(FittingModel.load(default_model_path()), appearance=True)
    faces = fit_faces(jaffe.samples, fitter)
    scheme = fitter.aam.scheme
    return PixelData(
        np.array(faces.samples + [None], dtype=object)[:-1],
        jaffe.labels()[faces.kept],
        jaffe.posers()[faces.kept],
        jaffe.errors + faces.errors,
        make_features=lambda variance: AAMAppearanceFeatures(scheme, variance, equalise=True),
        features_name=AAM_FEATURES_NAME,
    )


def load_pixel_data(folder: str | Path | None = None) -> PixelData:
    """Read JAFFE and crop every face (see :func:`aamcore.expression.features.crop_faces`)."""
    jaffe = load_jaffe(folder)
    crops = crop_faces(jaffe.samples)
    return PixelData(
        crops.pixels,
        jaffe.labels()[crops.kept],
        jaffe.posers()[crops.kept],
        jaffe.errors + crops.errors,
    )


@dataclass
class ExpressionBenchmark:
    """Results of :func:`run_expression_benchmark`.

    Attributes
    ----------
    results : dict
        ``results[n_classes][variance]``: one EvaluationResult per classifier.
    classify_ms : dict
        Per classifier kind: ``median`` and ``max`` milliseconds to classify
        one vector, and the ``feature_dim``.
    skipped : list of str
        Dataset files left out.
    """

    results: dict[int, dict[float, list[EvaluationResult]]]
    classify_ms: dict[str, dict[str, float]]
    skipped: list[str]
    features: str = BASELINE_NAME

    def best(self, n_classes: int) -> tuple[float, EvaluationResult]:
        """Variance and result of the highest overall rate for a class count."""
        candidates = [
            (variance, result)
            for variance, results in self.results[n_classes].items()
            for result in results
        ]
        return max(candidates, key=lambda vr: vr[1].overall_rate)

    def rate_passed(self, n_classes: int) -> bool:
        """Whether the best rate meets :data:`RATE_TARGETS`."""
        return self.best(n_classes)[1].overall_rate >= RATE_TARGETS[n_classes]

    def classify_passed(self) -> bool:
        """Whether every classifier's median time is under :data:`CLASSIFY_TARGET_MS`."""
        return all(t["median"] < CLASSIFY_TARGET_MS for t in self.classify_ms.values())

    def passed(self) -> bool:
        """All targets met."""
        return self.classify_passed() and all(self.rate_passed(n) for n in self.results)

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable summary, with every confusion matrix."""
        out: dict[str, Any] = {
            "features": self.features,
            "protocol": "leave-one-poser-out on JAFFE",
            "skipped": self.skipped,
            "classify_ms": self.classify_ms,
            "classify_target_ms": CLASSIFY_TARGET_MS,
            "classify_passed": self.classify_passed(),
            "class_sets": {},
        }
        for n, by_variance in self.results.items():
            variance, best = self.best(n)
            out["class_sets"][str(n)] = {
                "target": RATE_TARGETS[n],
                "passed": self.rate_passed(n),
                "best": {
                    "classifier": best.classifier,
                    "variance": variance,
                    "overall_rate": best.overall_rate,
                },
                "runs": [
                    {"variance": v} | r.to_dict() for v, rs in by_variance.items() for r in rs
                ],
            }
        return out


def time_classifiers(
    data: PixelData,
    variance: float,
    classifiers: Sequence[ClassifierSpec],
    repeats: int = 200,
) -> dict[str, dict[str, float]]:
    """Train every classifier kind on all seven classes, save, reload and time ``classify``.

    Returns
    -------
    dict
        Per kind: ``median`` and ``max`` ms over ``repeats`` single-vector
        calls, and ``feature_dim``.
    """
    features = data.make_features(variance).fit(data.pixels)(data.pixels)
    timings: dict[str, dict[str, float]] = {}
    with tempfile.TemporaryDirectory() as tmp, threadpool_limits(limits=1):
        for spec in classifiers:
            estimator = spec.fit(features, data.labels, data.posers)
            saved = ExpressionClassifier.from_estimator(estimator, BASELINE_FINGERPRINT).save(
                Path(tmp) / "classifier.npz"
            )
            classifier = ExpressionClassifier.load(saved)
            times = []
            for i in range(repeats):
                vector = features[i % len(features)]
                start = time.perf_counter()
                classifier.classify(vector)
                times.append(time.perf_counter() - start)
            ms = 1e3 * np.array(times)
            timings[spec.name] = {
                "median": float(np.median(ms)),
                "max": float(ms.max()),
                "feature_dim": float(features.shape[1]),
            }
    return timings


def _evaluate(
    data: PixelData,
    variances: Sequence[float],
    class_counts: Sequence[int],
    classifiers: Sequence[ClassifierSpec],
    progress: Callable[[str], None] | None,
) -> dict[int, dict[float, list[EvaluationResult]]]:
    """Leave-one-poser-out results per class count and kept variance.

    ``progress``, when given, is called with a line of text after each variance.
    """
    results: dict[int, dict[float, list[EvaluationResult]]] = {}
    for n in class_counts:
        subset = data.subset(restrict_classes(data.labels, CLASS_SETS[n]))
        results[n] = {}
        for variance in variances:
            results[n][variance] = leave_one_poser_out(
                subset.pixels,
                subset.labels,
                subset.posers,
                features=data.make_features(variance),
                classifiers=classifiers,
                class_names=CLASS_SETS[n],
            )
            if progress is not None:
                rates = ", ".join(
                    f"{r.classifier} {100 * r.overall_rate:.1f}%" for r in results[n][variance]
                )
                progress(f"{n} classes, {100 * variance:g}% variance: {rates}")
    return results


def run_expression_benchmark(
    variances: Sequence[float] = VARIANCES,
    class_counts: Sequence[int] = (7, 5),
    folder: str | Path | None = None,
    n_trials: int = 25,
    out_dir: str | Path | None = None,
    progress: Callable[[str], None] | None = None,
    C_grid: np.ndarray = C_GRID,
    gamma_grid: np.ndarray = GAMMA_GRID,
    data: PixelData | None = None,
) -> ExpressionBenchmark:
    """Run the benchmark; with ``out_dir``, write confusion tables, PNGs and ``results.json``.

    Parameters
    ----------
    variances : sequence of float
        Kept PCA variance fractions.
    class_counts : sequence of int
        7 and/or 5 (:data:`CLASS_SETS`).
    folder : path, optional
        JAFFE folder; ``<data root>/jaffe`` by default.
    n_trials : int
        k-means trials of eq 9.8 in each fold.
    out_dir : path, optional
        Where to write the outputs.
    progress : callable, optional
        Called with a line of text after each variance.
    C_grid, gamma_grid : 1-D arrays
        SVM hyper-parameters tried in each fold.
    data : PixelData, optional
        Face crops already computed by :func:`load_pixel_data` (then
        ``folder`` is not read).
    """
    classifiers = default_classifiers(n_trials, C_grid, gamma_grid)
    unknown = sorted(set(class_counts) - set(CLASS_SETS))
    if unknown:
        raise ValueError(f"class counts {unknown} unknown (expected some of {list(CLASS_SETS)})")
    data = data if data is not None else load_pixel_data(folder)
    results = _evaluate(data, variances, class_counts, classifiers, progress)
    bench = ExpressionBenchmark(results, {}, data.skipped, data.features_name)
    best_variance = bench.best(max(class_counts))[0]
    bench.classify_ms = time_classifiers(data, best_variance, classifiers)
    if out_dir is not None:
        write_outputs(bench, Path(out_dir))
    return bench


def _slug(text: str) -> str:
    return "".join(ch if ch.isalnum() else "_" for ch in text).strip("_").lower()


def write_outputs(bench: ExpressionBenchmark, out_dir: Path) -> None:
    """Write ``results.json``, ``confusions.txt`` and one PNG per confusion matrix."""
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "results.json").write_text(json.dumps(bench.to_dict(), indent=1))
    texts = []
    for n, by_variance in bench.results.items():
        for variance, results in by_variance.items():
            for result in results:
                texts.append(format_confusion(result))
                name = f"confusion_{n}classes_{100 * variance:g}pct_{_slug(result.classifier)}"
                save_confusion_png(result, out_dir / f"{name}.png")
    (out_dir / "confusions.txt").write_text("\n\n".join(texts) + "\n")


def format_benchmark(bench: ExpressionBenchmark) -> str:
    """The rate table, the best runs, PASS/FAIL lines and the best confusion matrices."""
    lines = [
        f"Expression recognition on JAFFE, leave-one-poser-out, features: {bench.features}",
    ]
    for n, by_variance in bench.results.items():
        names = [r.classifier for r in next(iter(by_variance.values()))]
        lines.append("")
        lines.append(f"{n} classes  variance  mean dim  " + "  ".join(f"{c:>15}" for c in names))
        for variance, results in by_variance.items():
            rates = "  ".join(f"{100 * r.overall_rate:14.1f}%" for r in results)
            lines.append(
                f"{'':9}  {100 * variance:7.1f}%  {results[0].mean_n_features():8.1f}  " + rates
            )
        variance, best = bench.best(n)
        lines.append(
            f"best, {n} classes: {best.classifier} at {100 * variance:g}% variance, "
            f"{100 * best.overall_rate:.1f}%"
        )
    lines.append("")
    for kind, t in bench.classify_ms.items():
        lines.append(
            f"classify one vector, {kind} (dim {t['feature_dim']:.0f}): "
            f"median {t['median']:.3f} ms, max {t['max']:.3f} ms"
        )
    lines.append("")
    for n in bench.results:
        best = bench.best(n)[1]
        verdict = "PASS" if bench.rate_passed(n) else "FAIL"
        lines.append(
            f"{verdict} {n} classes: best overall rate {100 * best.overall_rate:.1f}% "
            f"(target >= {100 * RATE_TARGETS[n]:g}%)"
        )
    slowest = max(t["median"] for t in bench.classify_ms.values())
    verdict = "PASS" if bench.classify_passed() else "FAIL"
    lines.append(
        f"{verdict} classify time: slowest median {slowest:.3f} ms "
        f"(target < {CLASSIFY_TARGET_MS:g} ms)"
    )
    for n in bench.results:
        lines.append("")
        lines.append(format_confusion(bench.best(n)[1]))
    if bench.skipped:
        lines.append("")
        lines.append(f"skipped {len(bench.skipped)} files: " + "; ".join(bench.skipped))
    return "\n".join(lines)
