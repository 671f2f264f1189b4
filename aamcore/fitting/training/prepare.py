"""Training a fitting model: everything the algorithms learn, on top of a trained AAM."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from pathlib import Path

from aamcore import defaults
from aamcore.config import cache_dir, resolve_dataset
from aamcore.detection.boxes import detect_all, match_detection
from aamcore.detection.haar import HaarFaceDetector
from aamcore.detection.mapping import fit_box_to_shape
from aamcore.fitting.model import FittingModel
from aamcore.fitting.training.descent import train_descent
from aamcore.fitting.training.update import scheme_for_level, train_update
from aamcore.io import FaceSample
from aamcore.model.aam import AAM
from aamcore.model.cache import cache_key, cached_file, training_samples
from aamcore.model.training import TrainConfig, train_aam
from aamcore.progress import bar, note

RECIPE = "fitting v7"
"""Names the training below in the cache key: change it when the training changes."""


def train_fitting_model(
    aam: AAM,
    samples: list[FaceSample],
    method: str = "jacobian",
    max_images: int | None = 60,
    descent_stages: int = 5,
    pyramid_levels: int = 2,
    progress: Callable[[Iterable[FaceSample]], Iterable[FaceSample]] | None = None,
) -> FittingModel:
    """Train what fitting ``aam`` needs, from its training ``samples``.

    That is the box-to-shape mapping (from Haar detections on ``samples``),
    the update matrices of the fixed-Jacobian fitter (``method``, on at most
    ``max_images`` images, one per pyramid level) and the supervised-descent
    cascade.
    """
    detections = detect_all(samples, HaarFaceDetector())
    mapping = fit_box_to_shape(aam.shape.mean_shape, [s.points for s in samples], detections)
    updates = [
        train_update(aam, samples, method, scheme_for_level(level), max_images, level=level,
                     progress=progress)
        for level in range(pyramid_levels)
    ]
    boxes = []
    for found, sample in zip(detections, samples, strict=True):
        k = match_detection(found, sample.points)
        boxes.append(None if k is None else found[k])
    cascade = train_descent(aam, samples, boxes, mapping, stages=descent_stages)
    return FittingModel(aam, mapping, updates, cascade)


def default_model_path(
    dataset: str = defaults.MODEL_DATASET,
    config: TrainConfig | None = None,
    max_images: int = defaults.MODEL_UPDATE_IMAGES,
    limit: int | None = None,
) -> Path:
    """Path of a cached fitting model, trained on first use (the stack's model by default).

    Parameters
    ----------
    dataset : str
        Dataset name or folder (``lfpw`` gives the 68-point iBUG markup that
        the head-pose model expects).
    config : TrainConfig, optional
        Defaults to grey textures over about 10k reference pixels.
    max_images : int
        Images used to learn the update matrices.
    limit : int, optional
        Train on the first ``limit`` images only (small models for tests).
    """
    config = config or TrainConfig(colour=False, shape_variance=0.98)
    folder = resolve_dataset(dataset)
    chosen = f"first {limit}" if limit else "all"
    key = cache_key(str(folder), config, {"select": chosen,
                                          "prepare": f"{RECIPE}, {max_images} images"})

    def build(path: Path) -> Path:
        start = time.perf_counter()
        samples, scheme = training_samples(folder, (lambda s: s[:limit]) if limit else None)
        note(f"training a fitting model on {len(samples)} images of {folder.name}, once: "
             f"it is kept in {path.parent}")
        aam = train_aam(samples, scheme, config, progress=bar("appearance model"),
                        source=f"{folder} [{chosen}]")
        model = train_fitting_model(aam, samples, max_images=max_images,
                                    progress=bar("update matrices"))
        note(f"fitting model trained in {time.perf_counter() - start:.0f} s")
        return model.save(path)

    return cached_file(cache_dir() / f"{folder.name}-{key}.npz", build, FittingModel.load)
