"""The JAFFE benchmark end to end, with small SVM grids to stay fast."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from aamcore.expression.benchmark import (
    RATE_TARGETS,
    ExpressionBenchmark,
    PixelData,
    format_benchmark,
    run_expression_benchmark,
)


@pytest.fixture(scope="module")
def out_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("bench")


@pytest.fixture(scope="module")
def bench(five_posers: PixelData, out_dir: Path) -> ExpressionBenchmark:
    return run_expression_benchmark(
        variances=(0.9,),
        class_counts=(5,),
        n_trials=2,
        out_dir=out_dir,
        C_grid=np.array([8.0]),
        gamma_grid=np.array([0.125]),
        data=five_posers,
    )


def test_every_classifier_runs_on_every_sample(
    bench: ExpressionBenchmark, five_posers: PixelData
) -> None:
    results = bench.results[5][0.9]
    assert [r.classifier for r in results] == ["LDA+Mahalanobis", "SVM OvA", "SVM OvO", "SVM DAG"]
    for r in results:
        assert len(r.y_true) == 77  # five posers without sadness and anger
        assert set(r.fold_params) == set(five_posers.posers)
        assert r.overall_rate > 0.35  # chance is 0.2
    assert set(bench.classify_ms) == {r.classifier for r in results}
    assert all(t["median"] > 0 for t in bench.classify_ms.values())


def test_table_names_the_baseline_and_gives_verdicts(bench: ExpressionBenchmark) -> None:
    text = format_benchmark(bench)
    assert "features: pixel PCA baseline" in text
    best = bench.best(5)[1]
    verdict = "PASS" if best.overall_rate >= RATE_TARGETS[5] else "FAIL"
    assert f"{verdict} 5 classes: best overall rate {100 * best.overall_rate:.1f}%" in text
    assert "classify time: slowest median" in text
    assert "Overall recognition rate" in text


def test_outputs_are_written(bench: ExpressionBenchmark, out_dir: Path) -> None:
    out = out_dir
    summary = json.loads((out / "results.json").read_text())
    assert summary["features"] == "pixel PCA baseline"
    assert summary["class_sets"]["5"]["target"] == 0.8
    assert len(summary["class_sets"]["5"]["runs"]) == 4
    assert len(list(out.glob("confusion_5classes_90pct_*.png"))) == 4
    assert (out / "confusions.txt").read_text().count("Overall recognition rate") == 4
