"""aamcore.evaluation.expression_variants: the JAFFE-only rows and each fold's references."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.evaluation.expression_variants import (
    JAFFE_ONLY,
    VARIANTS,
    Variant,
    composed_stream,
    fold_references,
    select,
    variant_named,
)


def test_the_jaffe_only_variant_and_the_rows() -> None:
    assert JAFFE_ONLY.blocks == ("hog", "shape") and JAFFE_ONLY.relative
    assert JAFFE_ONLY.classifier == "lda" and JAFFE_ONLY.test_stream == "balanced"
    assert JAFFE_ONLY.config().blocks == ("hog", "shape")
    assert VARIANTS[0] is JAFFE_ONLY and variant_named(JAFFE_ONLY.name) is JAFFE_ONLY
    assert len({v.name for v in VARIANTS}) == len(VARIANTS)
    assert select(["JAFFE only"]) == [JAFFE_ONLY]
    assert len(select(["thesis"])) == 4 and select() == list(VARIANTS)
    with pytest.raises(ValueError, match="no variant matches"):
        select(["lbp"])
    with pytest.raises(KeyError):
        variant_named("nothing")


@pytest.mark.parametrize("bad", [{"reference": "oracle"}, {"classifier": "logreg"},
                                 {"test_stream": "mixed"}, {"blocks": ("lbp",)},
                                 {"reference": "causal", "test_stream": "neutral-heavy"}])
def test_bad_variants_are_refused(bad: dict) -> None:
    with pytest.raises(ValueError):
        Variant("x", **({"blocks": ("hog",)} | bad))


def test_each_poser_gets_the_median_of_its_own_usable_faces() -> None:
    X = np.array([[1.0], [3.0], [5.0], [10.0], [20.0], [99.0]])
    labels = np.array(["NE", "HA", "SU", "NE", "HA", "SU"])
    posers = np.array(["A", "A", "A", "B", "B", "B"])
    usable = np.array([True, True, True, True, True, False])
    test = posers == "B"
    R = fold_references(X, labels, posers, usable, test, JAFFE_ONLY)
    np.testing.assert_allclose(R[:, 0], [3.0, 3.0, 3.0, 15.0, 15.0, 15.0])
    heavy = Variant("h", ("hog",), test_stream="neutral-heavy")
    R = fold_references(X, labels, posers, usable, test, heavy)
    assert R[0, 0] == 3.0 and R[3, 0] == 10.0  # B's stream: NE, NE, HA
    causal = fold_references(X, labels, posers, usable, test, Variant("c", ("hog",), "causal"))
    assert set(causal[:3, 0]) <= {1.0, 2.0, 3.0, 4.0, 5.0}


def test_a_neutral_heavy_stream_is_two_thirds_neutral() -> None:
    labels = np.array(["NE", "NE", "HA", "SU", "FE", "DI"])
    members = np.arange(6)
    assert composed_stream(labels, members, "balanced") is members
    stream = composed_stream(labels, members, "neutral-heavy")
    assert np.mean(labels[stream] == "NE") == pytest.approx(2 / 3)
    assert composed_stream(labels, np.array([2, 3]), "neutral-heavy").tolist() == [2, 3]
