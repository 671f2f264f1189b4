"""Where the face data and the cache of trained models live.

Both are one setting each, read from the environment so that tests, benchmarks
and services agree without passing paths around:

- ``AAMTRACK_DATA``: the data root, by default ``../shared/data`` beside the
  repository checkout.
- ``AAMTRACK_CACHE``: where trained models are cached, by default
  ``~/.cache/aamtrack``. Never inside the repository: models trained from the
  research-only data must not be committed.
"""

from __future__ import annotations

import os
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent


def data_root() -> Path:
    """Return the data root (``AAMTRACK_DATA`` or ``<repo>/../shared/data``)."""
    env = os.environ.get("AAMTRACK_DATA")
    if env:
        return Path(env).expanduser().resolve()
    return (REPO_ROOT.parent / "shared" / "data").resolve()


def cache_dir() -> Path:
    """Return the model cache folder, creating it if needed."""
    env = os.environ.get("AAMTRACK_CACHE")
    path = Path(env).expanduser() if env else Path.home() / ".cache" / "aamtrack"
    path.mkdir(parents=True, exist_ok=True)
    return path


def resolve_dataset(name_or_path: str | os.PathLike[str]) -> Path:
    """Map a dataset name (``imm_frontal``, ``lfpw``) or a path to a folder.

    ``lfpw`` means ``lfpw/trainset`` and ``helen`` ``helen/trainset``. A path
    that exists is returned as is.
    """
    path = Path(name_or_path).expanduser()
    if path.exists():
        return path.resolve()
    aliases = {"lfpw": "lfpw/trainset", "helen": "helen/trainset", "imm": "imm_frontal"}
    candidate = data_root() / aliases.get(str(name_or_path), str(name_or_path))
    if candidate.exists():
        return candidate
    raise FileNotFoundError(
        f"dataset {str(name_or_path)!r} is neither a folder nor a name under {data_root()} "
        "(set AAMTRACK_DATA to the data root)"
    )
