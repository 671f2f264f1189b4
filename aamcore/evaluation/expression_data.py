"""The expression benchmark's faces: every face of the three sets as the stack sees it, cached.

:func:`bench_faces` fits every face of the expression sets with a model as the stack
fits a stream's first frame (:func:`~aamcore.expression.faces.fit_faces`) and computes
its deployed feature vector and the quality gate's verdict; both are kept in the model
cache (named after the model's fingerprint, the algorithm and the versions of the fits
and features), so that the benchmark's runs reuse them. The blocks computed from the image
(HOG, shape) are what is kept; the appearance block, the fit's ``c`` itself, is appended
from the fits on load. :class:`BenchFaces` holds them
with the class, person (``set/person``), set and held-out flag of each face.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from aamcore.config import cache_dir
from aamcore.expression.analysis import observe
from aamcore.expression.faces import FACES_VERSION, LabelledFaces, fit_faces
from aamcore.expression.spec import FEATURE_VERSION, QualityLimits
from aamcore.expression.training import FEATURES, model_fingerprint
from aamcore.fitting.config import FITTER, FitterConfig
from aamcore.fitting.model import FittingModel
from aamcore.io.expression_sets import EXPRESSION_SETS, load_expression_set


@dataclass
class BenchFaces:
    """Every face of the benchmark with its features.

    Attributes
    ----------
    faces : LabelledFaces
    X : (n, d) float64 array
        Deployed feature vectors (zero where the gate refused the face, but for the
        :attr:`learnable` ones).
    problems : (n,) str array
        The gate's verdict without a shape template (``""``: classifiable).
    dims : dict
        Feature block lengths.
    learnable : (n,) bool array
        Faces a recipe may learn from: those the gate accepts and those it refuses only as
        blurred, as the deployed training (:func:`~aamcore.expression.training.gated`).
    """

    faces: LabelledFaces
    X: np.ndarray
    problems: np.ndarray
    dims: dict[str, int]
    learnable: np.ndarray

    @property
    def labels(self) -> np.ndarray:
        return self.faces.labels

    @property
    def sets(self) -> np.ndarray:
        return self.faces.sets

    @property
    def persons(self) -> np.ndarray:
        """``set/person`` of each face (n,): unique across sets."""
        return np.char.add(np.char.add(self.faces.sets.astype(str), "/"),
                           self.faces.posers.astype(str))

    @property
    def ok(self) -> np.ndarray:
        """Faces (n,) the gate accepts (before the shape template)."""
        return self.problems == ""

    @property
    def held(self) -> np.ndarray:
        """Faces (n,) of the held-out people (:mod:`aamcore.io.expression_sets`)."""
        from aamcore.io.expression_sets import is_held_out

        return np.array([is_held_out(s, p) for s, p in zip(self.faces.sets, self.faces.posers,
                                                           strict=True)], dtype=bool)

    def labelled_as_persons(self) -> BenchFaces:
        """The same faces with each person's faces of each class taken as one person: the
        sessions of streams that open on one expression and stay there."""
        faces = self.faces.subset(np.arange(len(self.labels)))
        faces.posers = np.char.add(np.char.add(faces.posers.astype(str), "#"),
                                   faces.labels.astype(str))
        return BenchFaces(faces, self.X, self.problems, self.dims, self.learnable)

    def subset(self, keep: np.ndarray) -> BenchFaces:
        index = np.flatnonzero(keep) if np.asarray(keep).dtype == bool else np.asarray(keep)
        return BenchFaces(self.faces.subset(index), self.X[index], self.problems[index],
                          self.dims, self.learnable[index])


BENCH_VERSION = 4
"""Bump when what the cache keeps changes (4: which faces a recipe may learn from, with their
features: blurred ones too)."""
IMAGE_FEATURES = FEATURES.with_blocks(tuple(b for b in FEATURES.blocks if b != "appearance"))
"""The deployed blocks the cache keeps: all but the appearance, which comes last."""


def _with_appearance(part: BenchFaces) -> BenchFaces:
    """``part`` with the appearance block appended to X when the deployed features have it
    (zero where the gate refused the face, as :func:`~aamcore.expression.analysis.observe`
    leaves refused rows)."""
    if "appearance" not in FEATURES.blocks:
        return part
    c = np.where(part.learnable[:, None], np.nan_to_num(part.faces.appearance), 0.0)
    c = c.astype(np.float32).astype(np.float64)  # as the bench keeps the other blocks
    return BenchFaces(part.faces, np.hstack([part.X, c]), part.problems,
                      part.dims | {"appearance": c.shape[1]}, part.learnable)


def _gate_key() -> str:
    """A short hash of the gate's default limits: the kept verdicts are the gate's."""
    text = json.dumps(asdict(QualityLimits()), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:8]


def _set_faces(model: Path, name: str, config: FitterConfig, say: Callable[[str], None]
               ) -> BenchFaces:
    stem = (f"expression-bench-{model_fingerprint(model)}-{config.algorithm}-{name}"
            f"-f{FACES_VERSION}-x{FEATURE_VERSION}-g{_gate_key()}-b{BENCH_VERSION}")
    path = cache_dir() / f"{stem}.npz"
    if path.is_file():
        faces = LabelledFaces.load(path)
        with np.load(path, allow_pickle=False) as f:
            if faces is not None and "X" in f:
                dims = {k: int(v) for k, v in zip(f["block_names"], f["block_dims"],
                                                  strict=True)}
                return BenchFaces(faces, f["X"], f["problems"], dims, f["learnable"])
    say(f"fitting every face of {name} once (kept in {path.parent})")
    faces = fit_faces(FittingModel.load(model), load_expression_set(name), config)
    observed = observe(faces.observations, IMAGE_FEATURES, QualityLimits(), learn_blurred=True)
    X, dims = observed.vectors(IMAGE_FEATURES.blocks), observed.dims(IMAGE_FEATURES.blocks)
    problems = np.array(observed.problems)
    tmp = path.with_name(f"{stem}.tmp.npz")
    faces.save(tmp)
    with np.load(tmp, allow_pickle=False) as f:
        saved = dict(f)
    np.savez(tmp, **saved, X=X.astype(np.float32), problems=problems,
             learnable=observed.learnable, block_names=np.array(list(dims)),
             block_dims=np.array(list(dims.values())))
    tmp.replace(path)
    return BenchFaces(faces, X.astype(np.float32).astype(np.float64), problems, dims,
                      observed.learnable)


def bench_faces(model: str | Path, sets: Sequence[str] = EXPRESSION_SETS,
                config: FitterConfig = FITTER, say: Callable[[str], None] | None = None
                ) -> BenchFaces:
    """Every face of ``sets`` fitted by ``model`` as ``config`` says, with its features
    (cached; module docstring)."""
    parts = [_with_appearance(_set_faces(Path(model), name, config, say or (lambda _: None)))
             for name in sets]
    return BenchFaces(LabelledFaces.concatenate([p.faces for p in parts]),
                      np.vstack([p.X for p in parts]), np.concatenate([p.problems for p in parts]),
                      parts[0].dims, np.concatenate([p.learnable for p in parts]))
