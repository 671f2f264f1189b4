"""Train models on first use and keep them in the cache folder.

A cached model's file name is derived from the dataset, the options and the
model format version, so a change of any of them trains a new one.
"""

from __future__ import annotations

import hashlib
import json
import logging
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path

from aamcore.config import cache_dir, resolve_dataset
from aamcore.io import FaceSample, load_annotated_folder
from aamcore.model.aam import AAM
from aamcore.model.file import FORMAT_VERSION, ModelFileError, load_model, save_model
from aamcore.model.training import TrainConfig, train_aam

log = logging.getLogger(__name__)


def cache_key(dataset: str, config: TrainConfig, extra: dict | None = None) -> str:
    """Short stable hash of what determines a trained model."""
    text = json.dumps(
        {
            "dataset": dataset,
            "config": asdict(config),
            "extra": extra or {},
            "format": FORMAT_VERSION,
        },
        sort_keys=True,
    )
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def cached_model(
    dataset: str,
    config: TrainConfig = TrainConfig(),
    select: Callable[[list[FaceSample]], list[FaceSample]] | None = None,
    select_name: str = "all",
    prepare: Callable[[AAM, list[FaceSample]], AAM] | None = None,
    prepare_name: str = "",
) -> Path:
    """Path of a model trained on ``dataset``, training and caching it if needed.

    Parameters
    ----------
    dataset : str
        Dataset name or folder (see :func:`aamcore.config.resolve_dataset`).
    config : TrainConfig
    select : callable, optional
        Picks the training samples (e.g. a subject split); ``select_name``
        names the choice in the cache key.
    prepare : callable, optional
        Adds to the trained model before it is saved (e.g. fitter training);
        ``prepare_name`` names it in the cache key.
    """
    folder = resolve_dataset(dataset)
    key = cache_key(str(folder), config, {"select": select_name, "prepare": prepare_name})
    path = cache_dir() / f"{folder.name}-{key}.npz"
    if path.is_file():
        try:
            load_model(path)
            return path
        except ModelFileError as exc:
            log.warning("retraining: cached model unusable: %s", exc)
    data = load_annotated_folder(folder)
    samples = select(data.samples) if select else data.samples
    log.info("training a model on %d images of %s (cached as %s)", len(samples), folder, path)
    aam = train_aam(samples, data.scheme, config, source=f"{folder} [{select_name}]")
    if prepare is not None:
        aam = prepare(aam, samples)
    return save_model(aam, path)
