"""aamcore.reproducible: the recipe trains the same model, byte for byte, whatever the
caller's BLAS threads."""

from __future__ import annotations

import hashlib
from pathlib import Path

from threadpoolctl import threadpool_limits

from aamcore.fitting.training.prepare import build_fitting_model


def _trained(path: Path, blas_threads: int) -> str:
    with threadpool_limits(limits=blas_threads, user_api="blas"):
        model = build_fitting_model(limit=30, max_images=3, aam_images=30)
    return hashlib.sha256(model.save(path).read_bytes()).hexdigest()


def test_two_trainings_of_the_recipe_give_the_same_file(tmp_path: Path) -> None:
    first = _trained(tmp_path / "a.npz", 2)
    assert _trained(tmp_path / "b.npz", 1) == first
