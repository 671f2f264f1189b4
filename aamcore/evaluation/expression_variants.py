"""The JAFFE-only expression pipelines of the leave-one-poser-out rows (:mod:`.expression_lopo`).

A :class:`Variant` names feature blocks and their weights, a reference and a
classifier, each trained on the other JAFFE posers alone. :data:`JAFFE_ONLY`, the
deployed pipeline before the three expression sets: HOG patches around the
51 inner landmarks plus the 68 landmarks in the canonical frame, relative to
the face's reference, weighted 1:1, shrinkage LDA. The comparison rows: the
blocks alone, without a reference, with a young (causal) reference, the RBF
SVM, and the thesis's classifiers (LDA + Mahalanobis, RBF SVMs) on the
fitter's appearance vector ``c``; one diagnostic measures the reference on a
stream made mostly of neutral faces.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from aamcore.expression.reference import median_of, poser_references
from aamcore.expression.spec import FeatureConfig

REFERENCES = ("none", "median", "causal")
TEST_STREAMS = ("balanced", "neutral-heavy")
FACE_CLASSIFIERS = ("lda", "rbf_svm", "logistic")
"""Classifiers of :func:`~aamcore.expression.face_classifier.fit_face_classifier`."""
THESIS_CLASSIFIERS = ("LDA+Mahalanobis", "SVM OvA", "SVM OvO", "SVM DAG")
"""The thesis's classifiers (:func:`~aamcore.expression.thesis_classifiers.default_classifiers`)."""
NEUTRAL = "NE"
NEUTRAL_SHARE = 2.0 / 3.0
"""Share of neutral faces in a ``neutral-heavy`` test stream."""


@dataclass(frozen=True)
class Variant:
    """One expression pipeline to score.

    Attributes
    ----------
    name : str
    blocks : tuple of str
        Feature blocks, in vector order.
    reference : {"none", "median", "causal"}
        ``none``: absolute features; ``median``: minus the median of all the
        poser's classifiable faces (no label used); ``causal``: minus the
        median of the poser's faces seen so far in a random order (the
        stream's reference at that moment).
    classifier : str
        One of :data:`FACE_CLASSIFIERS` (behind the block scaler) or
        :data:`THESIS_CLASSIFIERS` (on the raw vectors).
    weights : dict
        Block weights (1 when not named).
    test_stream : {"balanced", "neutral-heavy"}
        ``neutral-heavy`` is a diagnostic of a stream made mostly of neutral
        faces, as a live stream may be: the test poser's reference is taken
        over its faces with its neutral ones repeated to make
        :data:`NEUTRAL_SHARE` of them. It uses the test labels to compose that
        stream (never to classify), so it is no score of the protocol.
    """

    name: str
    blocks: tuple[str, ...]
    reference: str = "median"
    classifier: str = "lda"
    weights: Mapping[str, float] = field(default_factory=dict)
    test_stream: str = "balanced"

    def __post_init__(self) -> None:
        if self.reference not in REFERENCES:
            raise ValueError(f"reference {self.reference!r} not one of {REFERENCES}")
        if self.classifier not in FACE_CLASSIFIERS + THESIS_CLASSIFIERS:
            raise ValueError(f"classifier {self.classifier!r} not one of "
                             f"{FACE_CLASSIFIERS + THESIS_CLASSIFIERS}")
        if self.test_stream not in TEST_STREAMS:
            raise ValueError(f"test_stream {self.test_stream!r} not one of {TEST_STREAMS}")
        if self.test_stream != "balanced" and self.reference != "median":
            raise ValueError("a neutral-heavy test stream needs the median reference")
        FeatureConfig(blocks=self.blocks)  # raises ValueError on bad blocks

    @property
    def relative(self) -> bool:
        return self.reference != "none"

    def config(self, base: FeatureConfig | None = None) -> FeatureConfig:
        """The feature configuration of this variant's blocks."""
        return (base or FeatureConfig()).with_blocks(self.blocks)


JAFFE_ONLY = Variant("hog+shape (1:1), relative, LDA (JAFFE only, deployed before)",
                     ("hog", "shape"))
"""The pipeline the stack deployed before it learned from the three expression sets."""
VARIANTS: tuple[Variant, ...] = (
    JAFFE_ONLY,
    Variant("hog+shape (1:1), absolute, LDA", ("hog", "shape"), "none"),
    Variant("hog+shape (1:1), relative, logistic", ("hog", "shape"), classifier="logistic"),
    Variant("hog, relative, LDA", ("hog",)),
    Variant("hog, absolute, LDA", ("hog",), "none"),
    Variant("shape, relative, LDA", ("shape",)),
    Variant("hog+shape (1:1), relative, RBF SVM OvA", ("hog", "shape"), classifier="rbf_svm"),
    Variant("hog+shape (1:1), causal reference, LDA", ("hog", "shape"), "causal"),
    Variant("c, absolute, LDA", ("appearance",), "none"),
    *(Variant(f"c, absolute, {name} (thesis)", ("appearance",), "none", name)
      for name in THESIS_CLASSIFIERS),
    Variant("[diag.] hog+shape, relative, 2/3-NE test stream", ("hog", "shape"),
            test_stream="neutral-heavy"),
)
"""The rows of the benchmark table."""


def variant_named(name: str) -> Variant:
    """The variant of :data:`VARIANTS` called ``name``."""
    for variant in VARIANTS:
        if variant.name == name:
            return variant
    raise KeyError(f"no variant {name!r}; known: {[v.name for v in VARIANTS]}")


def select(only: list[str] | tuple[str, ...] = ()) -> list[Variant]:
    """The variants whose name contains one of ``only`` (all when empty).

    Raises
    ------
    ValueError
        When none matches.
    """
    chosen = [v for v in VARIANTS if not only or any(s in v.name for s in only)]
    if not chosen:
        raise ValueError(f"no variant matches {list(only)}; known: {[v.name for v in VARIANTS]}")
    return chosen


def composed_stream(labels: np.ndarray, members: np.ndarray, kind: str) -> np.ndarray:
    """Indices of the faces ``members`` as a test stream: as they are, or with the neutral
    ones repeated to make :data:`NEUTRAL_SHARE` of the stream (``neutral-heavy``)."""
    if kind == "balanced":
        return members
    neutral = members[labels[members] == NEUTRAL]
    others = len(members) - len(neutral)
    if len(neutral) == 0:
        return members
    copies = max(int(round(NEUTRAL_SHARE / (1 - NEUTRAL_SHARE) * others / len(neutral))), 1)
    return np.concatenate([members[labels[members] != NEUTRAL], np.tile(neutral, copies)])


def fold_references(
    X: np.ndarray,
    labels: np.ndarray,
    posers: np.ndarray,
    usable: np.ndarray,
    test: np.ndarray,
    variant: Variant,
    seed: int = 0,
) -> np.ndarray:
    """Each face's reference (n, d) in the fold that tests ``test`` (see :class:`Variant`).

    Parameters
    ----------
    X : (n, d) array
        Absolute feature vectors.
    labels, posers : (n,) str arrays
    usable : (n,) bool array
        Faces that may enter a reference (the classifiable ones).
    test : (n,) bool array
        The test poser's faces.
    variant : Variant
    seed : int
        Stream order of the causal reference.
    """
    order = np.random.default_rng(seed).permutation(len(X)) if variant.reference == "causal" \
        else None
    R = poser_references(X, posers, usable, order)
    members = np.flatnonzero(test & usable)
    if variant.test_stream != "balanced" and members.size:
        R[test] = median_of(X[composed_stream(labels, members, variant.test_stream)])
    return R
