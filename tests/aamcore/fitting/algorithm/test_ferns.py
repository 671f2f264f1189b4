"""aamcore.fitting.algorithm.ferns: the stage's checks, its file arrays, and the run-time
layout giving exactly what the training computes."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from aamcore.fitting.algorithm.ferns import FernRunner, FernStage
from aamcore.fitting.training.faces import PackedImages
from aamcore.fitting.training.ferns import fern_leaves


def random_stage(rng: np.random.Generator, n_points: int = 5, per: int = 3, depth: int = 4,
                 q: int = 7) -> FernStage:
    t = n_points * per
    return FernStage(np.repeat(np.arange(n_points), per),
                     rng.uniform(-12, 12, (t * depth, 4)).astype(np.float32),
                     rng.uniform(-40, 40, t * depth).astype(np.float32),
                     rng.normal(0, 1, (t * 2**depth, q)).astype(np.float32),
                     rng.normal(0, 1, q).astype(np.float32), depth, 12.0)


def test_stage_checks_and_arrays() -> None:
    rng = np.random.default_rng(0)
    stage = random_stage(rng)
    again = FernStage.from_arrays(stage.arrays("f"), "f")
    assert again.depth == 4 and again.radius == 12.0 and again.n_points == 5
    assert np.array_equal(again.weights, stage.weights)
    with pytest.raises(ValueError, match="grouped by landmark"):
        FernStage(stage.anchors[::-1].copy(), stage.offsets, stage.thresholds, stage.weights,
                  stage.bias, 4, 12.0)
    with pytest.raises(ValueError, match="offsets"):
        FernStage(stage.anchors, stage.offsets[:-1], stage.thresholds, stage.weights,
                  stage.bias, 4, 12.0)
    with pytest.raises(ValueError, match="weights"):
        FernStage(stage.anchors, stage.offsets, stage.thresholds, stage.weights[:-1],
                  stage.bias, 4, 12.0)


def test_runner_gives_what_the_training_computes() -> None:
    from aamcore.fitting.shape_space import ShapeSpace

    rng = np.random.default_rng(1)
    image = cv2.GaussianBlur(rng.integers(0, 255, (90, 120), np.uint8), (0, 0), 1.5)
    mean = rng.uniform(-20, 20, (5, 2))
    space = ShapeSpace.from_model(mean, np.linalg.qr(rng.normal(size=(10, 2)))[0],
                                  np.ones(2), (0, 1))
    stage = random_stage(rng)
    runner = FernRunner(stage)
    packed = PackedImages.pack([image])
    for k in range(10):
        # shapes inside, across and beyond the border: clamped the same way
        shape = space.mean * rng.uniform(0.5, 2.0) + rng.uniform([-10, -10], [130, 100])
        a, b = space.similarity(shape[None])[0]
        rot = np.array([[a, -b], [b, a]])
        values = runner.values(image.ravel(), image.shape[1],
                               (image.shape[1] - 1.0, image.shape[0] - 1.0), shape, rot)
        leaves = fern_leaves(packed, np.zeros(1, np.int64), shape[None], space, stage)
        expected = stage.weights.astype(np.float64)[leaves[0]].sum(axis=0) + stage.bias
        assert np.allclose(runner.output(values), expected, atol=1e-4), k
