"""Train models on first use and keep them in the cache folder.

A cached model's file name is derived from the dataset, the options and the
model format version, so a change of any of them trains a new one. Processes that want
the same model at once train it once: the first takes the file's lock
(``NAME.npz.lock`` beside it) and trains, the others wait for it and load what it saved.
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import logging
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import asdict
from pathlib import Path

from aamcore.config import cache_dir, resolve_dataset
from aamcore.io import FaceSample, load_annotated_folder
from aamcore.io.landmarks import LandmarkScheme
from aamcore.model.file import FORMAT_VERSION, ModelFileError, load_model, save_model
from aamcore.model.training import TrainConfig, train_aam

log = logging.getLogger(__name__)

Select = Callable[[list[FaceSample]], list[FaceSample]]


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


def cached_file(
    path: Path, build: Callable[[Path], Path], check: Callable[[Path], object] = load_model
) -> Path:
    """``path`` if it holds a usable model (``check`` loads it), else ``build(path)``; a
    process that finds another building it waits and takes what that one saved."""
    if _usable(path, check, quiet=True):
        return path
    with locked(path):
        if _usable(path, check, quiet=False):  # built meanwhile by the lock's holder
            return path
        return build(path)


def _usable(path: Path, check: Callable[[Path], object], quiet: bool) -> bool:
    if not path.is_file():
        return False
    try:
        check(path)
        return True
    except ModelFileError as exc:
        if not quiet:
            log.warning("retraining: cached model unusable: %s", exc)
        return False


@contextmanager
def locked(path: Path) -> Iterator[None]:
    """Hold the inter-process lock of cache file ``path`` (``path.lock``, made if needed),
    waiting while another process holds it; released when the process ends, however."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path.with_name(path.name + ".lock"), "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def cached_model(
    dataset: str,
    config: TrainConfig = TrainConfig(),
    select: Select | None = None,
    select_name: str = "all",
) -> Path:
    """Path of an AAM trained on ``dataset``, training and caching it if needed.

    Parameters
    ----------
    dataset : str
        Dataset name or folder (see :func:`aamcore.config.resolve_dataset`).
    config : TrainConfig
    select : callable, optional
        Picks the training samples (e.g. a subject split); ``select_name``
        names the choice in the cache key.
    """
    folder = resolve_dataset(dataset)
    key = cache_key(str(folder), config, {"select": select_name})

    def build(path: Path) -> Path:
        samples, scheme = training_samples(folder, select)
        log.info("training a model on %d images of %s (cached as %s)", len(samples), folder, path)
        return save_model(train_aam(samples, scheme, config, source=f"{folder} [{select_name}]"),
                          path)

    return cached_file(cache_dir() / f"{folder.name}-{key}.npz", build)


def training_samples(
    folder: Path, select: Select | None = None
) -> tuple[list[FaceSample], LandmarkScheme]:
    """The samples of ``folder`` that ``select`` keeps, and the folder's landmark scheme."""
    data = load_annotated_folder(folder)
    return (select(data.samples) if select else data.samples), data.scheme
