"""A trained expression classifier with its feature pipeline, saved and loaded without pickle.

A classifier file is one ``.npz`` archive. Its ``header`` entry holds UTF-8 JSON bytes::

    {"format": "aamtrack-expression-classifier", "format_version": 5,
     "kind": "linear", "class_names": ["NE", ...], "feature_dim": 1972,
     "aam_fingerprint": "...", "info": {...}, "pipeline": {...},
     "temperature": 0.8, "absolute_temperature": 0.8, "has_absolute": true,
     "absolute_weight": 0.25, "fused_temperature": 1.0}

and every other entry is a plain numeric array of the pure numpy predictor (a
:mod:`~aamcore.expression.scores` model) or the pipeline's shape template
(``pipeline_template``), so the archive loads with ``allow_pickle=False``. A relative
pipeline's file also holds a person-independent ``LinearModel`` or
:class:`~aamcore.expression.network.NetworkModel` of the absolute vectors (entries
``absolute_*``), which decides until the stream has a reference; once it has, the two
models' log-probabilities are fused, the absolute one weighted by ``absolute_weight``
(:func:`~aamcore.expression.learning.fuse`). Each ``temperature`` turns scores into
probabilities (:mod:`~aamcore.expression.calibration`), fitted on held-out people.

``pipeline`` is the :class:`~aamcore.expression.spec.PipelineSpec`: which features are
classified, relative to which reference, behind which quality gate. ``aam_fingerprint``
names the fitting model whose fits the classifier was trained on: landmarks and appearance
vectors of another model have another meaning, and :meth:`ExpressionClassifier.check_aam`
refuses them. Refused at load, each with what to do: another format version, features of
another :data:`~aamcore.expression.spec.FEATURE_VERSION`, a pipeline whose vectors do not
fit the model.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeAlias

import numpy as np

from aamcore.expression.calibration import softmax
from aamcore.expression.crop import N_LANDMARKS
from aamcore.expression.learning import Learned, fuse
from aamcore.expression.network import NetworkModel, stored_model
from aamcore.expression.scores import FittedFaceClassifier, LinearModel, thesis_model
from aamcore.expression.spec import FEATURE_VERSION, PipelineSpec
from aamcore.io.versioned import checked_header, save_npz

if TYPE_CHECKING:  # the thesis's models come with scikit-learn: imported where they are used
    from aamcore.expression.lda import FisherMahalanobis, MahalanobisModel
    from aamcore.expression.svm import SVMExpressionClassifier, SVMModel

FORMAT_NAME = "aamtrack-expression-classifier"
FORMAT_VERSION = 5
KINDS = ("linear", "lda_mahalanobis", "svm_ova", "svm_ovo", "svm_dag", "network")
_HEADER = "header"
_TEMPLATE = "pipeline_template"
_ABSOLUTE = "absolute_"


class ClassifierFileError(ValueError):
    """A classifier file is missing, malformed or of another format version (named)."""


class AAMMismatchError(ValueError):
    """A classifier is used with fits of another fitting model than it was trained on."""


Model: TypeAlias = "LinearModel | MahalanobisModel | SVMModel | NetworkModel"
Absolute = LinearModel | NetworkModel


@dataclass(frozen=True)
class ExpressionClassifier:
    """A trained expression classifier and the pipeline that makes the vectors it classifies.

    Attributes
    ----------
    kind : str
        One of :data:`KINDS`.
    class_names : tuple of str
        Class of each score column.
    aam_fingerprint : str
        Identifies the fitting model whose fits the classifier expects.
    model : LinearModel, MahalanobisModel or SVMModel
        The pure numpy predictor.
    pipeline : PipelineSpec
        How the vectors classified are computed from a fit and its frame.
    info : dict
        Free JSON-serialisable notes (parameters, features, training set).
    temperature : float
        Of the softmax that makes :meth:`probabilities` of the scores.
    absolute : LinearModel, NetworkModel or None
        The person-independent model of absolute vectors (relative pipelines).
    absolute_temperature : float
        Of :meth:`absolute_probabilities`.
    absolute_weight : float
        Weight of the absolute model's log-probabilities in :meth:`fused_probabilities`.
    fused_temperature : float
        Of the fused scores' softmax.
    """

    kind: str
    class_names: tuple[str, ...]
    aam_fingerprint: str
    model: Model
    pipeline: PipelineSpec
    info: dict[str, Any] = field(default_factory=dict)
    temperature: float = 1.0
    absolute: Absolute | None = None
    absolute_temperature: float = 1.0
    absolute_weight: float = 0.0
    fused_temperature: float = 1.0

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"unknown classifier kind {self.kind!r} (expected one of {KINDS})")
        expected = {"linear": LinearModel, "network": NetworkModel}.get(self.kind) \
            or thesis_model(self.kind)
        if not isinstance(self.model, expected):
            raise ValueError(f"a {self.kind} classifier needs a {expected.__name__}")
        if self.kind == "lda_mahalanobis":
            n_scores = len(self.model.centroids)
        else:
            n_scores = self.model.n_classes
        if n_scores != len(self.class_names):
            raise ValueError(f"model has {n_scores} classes, {len(self.class_names)} names given")
        if self.pipeline.feature_dim != self.feature_dim:
            raise ValueError(f"the pipeline makes vectors of length {self.pipeline.feature_dim}, "
                             f"the model expects {self.feature_dim}")
        if self.absolute is not None and (self.absolute.feature_dim != self.feature_dim
                                          or self.absolute.n_classes != len(self.class_names)):
            raise ValueError("the absolute model does not match the classifier's vectors or "
                             "classes")
        if not (self.temperature > 0 and self.absolute_temperature > 0
                and self.fused_temperature > 0):
            raise ValueError("temperatures must be > 0")
        if not self.absolute_weight >= 0:
            raise ValueError(f"absolute_weight must be >= 0, got {self.absolute_weight}")

    @property
    def feature_dim(self) -> int:
        """Length d of the feature vectors classified."""
        return self.model.feature_dim

    @classmethod
    def from_face_classifier(
        cls,
        fitted: FittedFaceClassifier,
        pipeline: PipelineSpec,
        aam_fingerprint: str,
        info: dict[str, Any] | None = None,
        temperature: float = 1.0,
        absolute: FittedFaceClassifier | None = None,
        absolute_temperature: float = 1.0,
    ) -> ExpressionClassifier:
        """Wrap a classifier of :func:`~aamcore.expression.face_classifier.fit_face_classifier`
        with the pipeline that makes its vectors, and the person-independent linear model of
        absolute vectors (or network) when there is one (with the same classes)."""
        notes = {"classifier_params": fitted.params} | dict(info or {})
        model = None
        if absolute is not None:
            if absolute.classes != fitted.classes \
                    or not isinstance(absolute.model, LinearModel | NetworkModel):
                raise ValueError("the absolute model must be linear or a network, with the "
                                 "same classes")
            model = absolute.model
        return cls(fitted.kind, fitted.classes, aam_fingerprint, fitted.model, pipeline, notes,
                   temperature, model, absolute_temperature)

    @classmethod
    def from_learned(cls, learned: Learned, pipeline: PipelineSpec, aam_fingerprint: str,
                     info: dict[str, Any] | None = None) -> ExpressionClassifier:
        """The models of :func:`~aamcore.expression.learning.learn`: the relative one with the
        absolute one beside it, or the absolute one alone (then ``pipeline`` is absolute)."""
        absolute, notes = learned.absolute, {"classifier_params": learned.absolute.params}
        info = {"absolute_params": absolute.params} | dict(info or {})
        if learned.relative is None:
            if pipeline.relative:
                raise ValueError("a relative pipeline needs the relative model")
            return cls(absolute.kind, absolute.classes, aam_fingerprint, absolute.model,
                       pipeline, notes | dict(info or {}), learned.absolute_temperature)
        made = cls.from_face_classifier(learned.relative, pipeline, aam_fingerprint, info,
                                        learned.temperature, absolute,
                                        learned.absolute_temperature)
        return replace(made, absolute_weight=learned.absolute_weight,
                       fused_temperature=learned.fused_temperature)

    @classmethod
    def from_estimator(cls, estimator: FisherMahalanobis | SVMExpressionClassifier,
                       aam_fingerprint: str, pipeline: PipelineSpec,
                       info: dict[str, Any] | None = None, temperature: float = 1.0
                       ) -> ExpressionClassifier:
        """Wrap a fitted :class:`FisherMahalanobis` or :class:`SVMExpressionClassifier`
        (the thesis's classifiers) with the pipeline that makes its vectors."""
        from aamcore.expression.lda import FisherMahalanobis
        from aamcore.expression.svm import SVMExpressionClassifier

        if isinstance(estimator, FisherMahalanobis):
            kind = "lda_mahalanobis"
        elif isinstance(estimator, SVMExpressionClassifier):
            kind = f"svm_{estimator.scheme}"
        else:
            raise TypeError(f"cannot wrap a {type(estimator).__name__}")
        if not hasattr(estimator, "model_"):
            raise ValueError("the estimator is not fitted")
        names = tuple(str(c) for c in estimator.classes_)
        return cls(kind, names, aam_fingerprint, estimator.model_, pipeline, dict(info or {}),
                   temperature)

    def scores(self, X: np.ndarray) -> np.ndarray:
        """Per-class scores of the rows of X (n, k), shape (n, n_classes); higher is likelier."""
        X = np.asarray(X, dtype=np.float64)
        if X.ndim != 2 or X.shape[1] != self.feature_dim:
            raise ValueError(f"expected vectors of shape (n, {self.feature_dim}), got {X.shape}")
        return self.model.scores(X)

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Class name of each row of X (n, k), shape (n,)."""
        return np.array(self.class_names)[np.argmax(self.scores(X), axis=1)]

    def probabilities(self, X: np.ndarray) -> np.ndarray:
        """Calibrated class probabilities (n, n_classes) of the rows of X (n, k); rows sum to 1."""
        return softmax(self.scores(X), self.temperature)

    def absolute_probabilities(self, X: np.ndarray) -> np.ndarray:
        """The person-independent model's probabilities (n, n_classes) of absolute vectors.

        Raises
        ------
        ValueError
            When the classifier has no absolute model.
        """
        if self.absolute is None:
            raise ValueError("this classifier has no person-independent model")
        X = np.asarray(X, dtype=np.float64)
        if X.ndim != 2 or X.shape[1] != self.feature_dim:
            raise ValueError(f"expected vectors of shape (n, {self.feature_dim}), got {X.shape}")
        return softmax(self.absolute.scores(X), self.absolute_temperature)

    def fused_probabilities(self, relative: np.ndarray, absolute: np.ndarray) -> np.ndarray:
        """The relative model's probabilities of ``relative`` (n, k) fused with the absolute
        model's of ``absolute`` (n, k) (the same faces' vectors), (n, n_classes).

        Raises
        ------
        ValueError
            When the classifier has no person-independent model.
        """
        if self.absolute is None:
            raise ValueError("this classifier has no person-independent model")
        return fuse(self.scores(relative), self.absolute.scores(np.asarray(absolute, np.float64)),
                    self.temperature, self.absolute_temperature, self.absolute_weight,
                    self.fused_temperature)

    def check_fit(self, scheme: str, n_landmarks: int, appearance_dim: int) -> None:
        """Refuse fits of another landmark scheme than the pipeline's, or of another appearance
        length when the pipeline classifies the appearance (none at all is taken beside the
        image's blocks: a failed fit's, filled with zeros).

        Raises
        ------
        AAMMismatchError
            If the fit does not match the pipeline.
        """
        spec = self.pipeline
        if scheme != spec.scheme or n_landmarks != N_LANDMARKS:
            raise AAMMismatchError(
                f"this expression classifier was trained on {spec.scheme} fits "
                f"({N_LANDMARKS} landmarks), not on {scheme} fits with {n_landmarks} landmarks: "
                "retrain it for this fitting model"
            )
        blocks = spec.features.blocks
        filled = appearance_dim == 0 and len(blocks) > 1
        if "appearance" in blocks and appearance_dim != spec.appearance_dim and not filled:
            raise AAMMismatchError(
                f"this expression classifier was trained on fits with {spec.appearance_dim} "
                f"appearance parameters, this fit has {appearance_dim}: retrain it for this AAM"
            )

    def check_aam(self, fingerprint: str) -> None:
        """Refuse an AAM other than the one the classifier was trained on.

        Raises
        ------
        AAMMismatchError
            If ``fingerprint`` differs from :attr:`aam_fingerprint`.
        """
        if fingerprint != self.aam_fingerprint:
            raise AAMMismatchError(
                f"this expression classifier was trained on the fits of model "
                f"{self.aam_fingerprint!r}, not of model {fingerprint!r}: retrain it for this AAM"
            )

    def header(self) -> dict[str, Any]:
        """The JSON header written to the file."""
        return {
            "format": FORMAT_NAME,
            "format_version": FORMAT_VERSION,
            "kind": self.kind,
            "class_names": list(self.class_names),
            "feature_dim": self.feature_dim,
            "aam_fingerprint": self.aam_fingerprint,
            "info": self.info,
            "pipeline": self.pipeline.to_json(),
            "temperature": self.temperature,
            "absolute_temperature": self.absolute_temperature,
            "has_absolute": self.absolute is not None,
            "absolute_weight": self.absolute_weight,
            "fused_temperature": self.fused_temperature,
        }

    def save(self, path: str | Path) -> Path:
        """Write the classifier to ``path`` (``.npz`` is appended if missing); return the path."""
        path = Path(path)
        if path.suffix != ".npz":
            path = path.with_name(path.name + ".npz")
        text = json.dumps(self.header(), sort_keys=True)
        header = np.frombuffer(text.encode("utf-8"), dtype=np.uint8)
        arrays = {k: np.asarray(v) for k, v in self.model.to_arrays().items()}
        if self.pipeline.template is not None:
            arrays[_TEMPLATE] = np.asarray(self.pipeline.template, np.float64)
        if self.absolute is not None:
            arrays |= {_ABSOLUTE + k: np.asarray(v) for k, v in self.absolute.to_arrays().items()}
        save_npz(path, {_HEADER: header, **arrays})
        return path

    @classmethod
    def load(cls, path: str | Path) -> ExpressionClassifier:
        """Read a classifier file written by :meth:`save`.

        Raises
        ------
        ClassifierFileError
            If the file is missing, not a classifier file, of another format
            version, or its arrays are missing or inconsistent.
        """
        path = Path(path)
        if not path.is_file():
            raise ClassifierFileError(f"{path}: classifier file not found")
        try:
            with np.load(path, allow_pickle=False) as archive:
                arrays = {name: archive[name] for name in archive.files}
        except (OSError, ValueError) as exc:
            raise ClassifierFileError(f"{path}: not a readable .npz archive ({exc})") from exc
        header = _read_header(path, arrays.pop(_HEADER, None))
        kind = header["kind"]
        names = tuple(header["class_names"])
        template = arrays.pop(_TEMPLATE, None)
        absolute = {k.removeprefix(_ABSOLUTE): arrays.pop(k) for k in list(arrays)
                    if k.startswith(_ABSOLUTE)}
        try:
            pipeline = PipelineSpec.from_json(header["pipeline"], template)
            if bool(header["has_absolute"]) != bool(absolute):
                raise ValueError("the absolute model's arrays do not match the header")
            if kind in ("linear", "network"):
                model: Model = stored_model(arrays)
            elif kind == "lda_mahalanobis":
                model = thesis_model(kind).from_arrays(arrays)
            else:
                model = thesis_model(kind).from_arrays(arrays, kind.removeprefix("svm_"),
                                                        len(names))
            classifier = cls(kind, names, header["aam_fingerprint"], model, pipeline,
                             header["info"], float(header["temperature"]),
                             stored_model(absolute) if absolute else None,
                             float(header["absolute_temperature"]),
                             float(header["absolute_weight"]),
                             float(header["fused_temperature"]))
        except (KeyError, ValueError, TypeError, IndexError) as exc:
            raise ClassifierFileError(f"{path}: inconsistent classifier arrays ({exc})") from exc
        if classifier.feature_dim != header["feature_dim"]:
            raise ClassifierFileError(
                f"{path}: header says feature_dim {header['feature_dim']}, "
                f"arrays have {classifier.feature_dim}"
            )
        return classifier


def _read_header(path: Path, raw: np.ndarray | None) -> dict[str, Any]:
    """Decode and check the JSON header of a classifier file."""
    header = checked_header(path, raw, FORMAT_NAME, FORMAT_VERSION, "classifier",
                            "retrain it (aamtrack model prepare trains the stack's; format 1 "
                            "classified raw appearance vectors, format 2 had no probabilities, "
                            "format 3 learned from JAFFE alone, format 4 had no network)",
                            ClassifierFileError)
    needed = {"kind", "class_names", "feature_dim", "aam_fingerprint", "info", "pipeline",
              "temperature", "absolute_temperature", "has_absolute", "absolute_weight",
              "fused_temperature"}
    missing = needed - set(header)
    if missing:
        raise ClassifierFileError(f"{path}: header lacks {', '.join(sorted(missing))}")
    if header["kind"] not in KINDS:
        raise ClassifierFileError(f"{path}: unknown classifier kind {header['kind']!r}")
    pipeline = header["pipeline"]
    found = pipeline.get("feature_version") if isinstance(pipeline, dict) else None
    if found != FEATURE_VERSION:
        raise ClassifierFileError(
            f"{path}: the classifier was trained on face features of version {found}, this "
            f"aamtrack computes version {FEATURE_VERSION}: retrain the classifier"
        )
    return header
