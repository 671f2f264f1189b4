"""aamcore.evaluation.expression_lopo: JAFFE-only pipelines leave-one-poser-out over all faces,
nothing of the test poser in its fold, the table and the outputs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from aamcore.evaluation.expression_lopo import (
    ALL_BLOCKS,
    ExpressionBenchmark,
    evaluate_variant,
    run_expression_benchmark,
    thesis_specs,
)
from aamcore.evaluation.expression_report import format_benchmark, write_outputs
from aamcore.evaluation.expression_results import NOT_CLASSIFIED
from aamcore.evaluation.expression_variants import JAFFE_ONLY, Variant
from aamcore.expression.analysis import observe
from aamcore.expression.faces import LabelledFaces
from aamcore.expression.lda import FisherMahalanobis
from aamcore.expression.thesis_classifiers import ClassifierSpec


@pytest.fixture(scope="module")
def bench(jaffe: LabelledFaces, model_path: Path) -> ExpressionBenchmark:
    rows = [JAFFE_ONLY, Variant("c, absolute, SVM OvA (thesis)", ("appearance",), "none",
                              "SVM OvA")]
    thesis = thesis_specs(2, np.array([8.0]), np.array([0.5]))
    return run_expression_benchmark(model_path, variants=rows, class_counts=(5,),
                                    thesis=thesis, faces=jaffe)


def test_every_face_of_the_class_set_is_scored(bench: ExpressionBenchmark) -> None:
    deployed = bench.results[JAFFE_ONLY.name][5]
    assert bench.n_faces == 213 and deployed.n == 152
    assert set(deployed.test_poser) == {"KA", "KL", "KM", "KR", "MK", "NA", "NM", "TM", "UY",
                                        "YM"}
    assert deployed.overall_rate > 0.7  # the small test model; the bench's model does better
    assert bench.results["c, absolute, SVM OvA (thesis)"][5].n == 152


def test_a_face_without_a_fit_counts_wrong(jaffe: LabelledFaces) -> None:
    faces = jaffe.subset(np.arange(213))
    faces.landmarks[0], faces.appearance[0] = np.nan, np.nan
    faces.reasons = np.where(np.arange(213) == 0, "no face", faces.reasons)
    observed = observe(faces.observations, ALL_BLOCKS)
    row = Variant("c, absolute, LDA", ("appearance",), "none")
    result = evaluate_variant(faces, observed, row, 7)
    assert result.n == 213 and result.y_pred[0] == NOT_CLASSIFIED
    assert result.refused == [f"{jaffe.names[0]}: no face"]


def test_no_fold_trains_on_the_test_poser(jaffe: LabelledFaces) -> None:
    trained_on: list[set[str]] = []

    def fit(X: np.ndarray, y: np.ndarray, groups: np.ndarray) -> FisherMahalanobis:
        trained_on.append(set(groups))
        return FisherMahalanobis(n_components=3).fit(X, y)

    observed = observe(jaffe.observations, ALL_BLOCKS)
    row = Variant("c, thesis LDA", ("appearance",), "none", "LDA+Mahalanobis")
    result = evaluate_variant(jaffe, observed, row, 5, thesis={"LDA+Mahalanobis":
                                                               ClassifierSpec("LDA 3", fit)})
    posers = sorted(set(jaffe.posers))
    assert [set(posers) - t for t in trained_on] == [{p} for p in posers]
    assert set(result.fold_params) == set(posers)
    assert result.fold_params["KA"]["n_components"] == 3


def test_the_table_and_the_outputs(bench: ExpressionBenchmark, tmp_path: Path) -> None:
    text = format_benchmark(bench)
    assert JAFFE_ONLY.name in text and "c, absolute, SVM OvA (thesis)" in text
    assert "Overall recognition rate" in text
    write_outputs(bench, tmp_path)
    data = json.loads((tmp_path / "results.json").read_text())
    assert data["rows"][JAFFE_ONLY.name]["5"]["n_samples"] == 152
    assert len(list(tmp_path.glob("confusion_5classes_*.png"))) == 2
    with pytest.raises(ValueError, match="class counts"):
        run_expression_benchmark("x", class_counts=(6,))
