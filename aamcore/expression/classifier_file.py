"""A trained expression classifier, saved and loaded without pickle.

A classifier file is one ``.npz`` archive. Its ``header`` entry holds UTF-8
JSON bytes::

    {"format": "aamtrack-expression-classifier", "format_version": 1,
     "kind": "svm_dag", "class_names": ["NE", ...], "feature_dim": 17,
     "aam_fingerprint": "...", "info": {...}}

and every other entry is a plain numeric array of the pure numpy predictor
(:class:`~aamcore.expression.lda.MahalanobisModel` or
:class:`~aamcore.expression.svm.SVMModel`), so the archive loads with
``allow_pickle=False``. ``aam_fingerprint`` names the AAM whose appearance
vectors ``c`` the classifier was trained on: appearance vectors of another AAM
have another meaning, and :meth:`ExpressionClassifier.check_aam` refuses them.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from aamcore.expression.lda import FisherMahalanobis, MahalanobisModel
from aamcore.expression.svm import SVMExpressionClassifier, SVMModel
from aamcore.io.versioned import checked_header

FORMAT_NAME = "aamtrack-expression-classifier"
FORMAT_VERSION = 1
KINDS = ("lda_mahalanobis", "svm_ova", "svm_ovo", "svm_dag")
_HEADER = "header"


class ClassifierFileError(ValueError):
    """A classifier file is missing, malformed or of another format version (named)."""


class AAMMismatchError(ValueError):
    """A classifier is used with appearance vectors of another AAM than it was trained on."""


Model = MahalanobisModel | SVMModel


@dataclass(frozen=True)
class ExpressionClassifier:
    """A trained expression classifier of appearance vectors.

    Attributes
    ----------
    kind : str
        One of :data:`KINDS`.
    class_names : tuple of str
        Class of each score column.
    aam_fingerprint : str
        Identifies the AAM whose appearance vectors the classifier expects.
    model : MahalanobisModel or SVMModel
        The pure numpy predictor.
    info : dict
        Free JSON-serialisable notes (parameters, features, training set).
    """

    kind: str
    class_names: tuple[str, ...]
    aam_fingerprint: str
    model: Model
    info: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"unknown classifier kind {self.kind!r} (expected one of {KINDS})")
        expected = MahalanobisModel if self.kind == "lda_mahalanobis" else SVMModel
        if not isinstance(self.model, expected):
            raise ValueError(f"a {self.kind} classifier needs a {expected.__name__}")
        if isinstance(self.model, MahalanobisModel):
            n_scores = len(self.model.centroids)
        else:
            n_scores = self.model.n_classes
        if n_scores != len(self.class_names):
            raise ValueError(f"model has {n_scores} classes, {len(self.class_names)} names given")

    @property
    def feature_dim(self) -> int:
        """Length k of the appearance vectors classified."""
        return self.model.feature_dim

    @classmethod
    def from_estimator(
        cls,
        estimator: FisherMahalanobis | SVMExpressionClassifier,
        aam_fingerprint: str,
        info: dict[str, Any] | None = None,
    ) -> ExpressionClassifier:
        """Wrap a fitted :class:`FisherMahalanobis` or :class:`SVMExpressionClassifier`."""
        if isinstance(estimator, FisherMahalanobis):
            kind = "lda_mahalanobis"
        elif isinstance(estimator, SVMExpressionClassifier):
            kind = f"svm_{estimator.scheme}"
        else:
            raise TypeError(f"cannot wrap a {type(estimator).__name__}")
        if not hasattr(estimator, "model_"):
            raise ValueError("the estimator is not fitted")
        names = tuple(str(c) for c in estimator.classes_)
        return cls(kind, names, aam_fingerprint, estimator.model_, dict(info or {}))

    def scores(self, X: np.ndarray) -> np.ndarray:
        """Per-class scores of the rows of X (n, k), shape (n, n_classes); higher is likelier."""
        X = np.asarray(X, dtype=np.float64)
        if X.ndim != 2 or X.shape[1] != self.feature_dim:
            raise ValueError(f"expected vectors of shape (n, {self.feature_dim}), got {X.shape}")
        return self.model.scores(X)

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Class name of each row of X (n, k), shape (n,)."""
        return np.array(self.class_names)[np.argmax(self.scores(X), axis=1)]

    def classify(self, c: np.ndarray) -> tuple[str, np.ndarray]:
        """Classify one appearance vector.

        Parameters
        ----------
        c : (k,) array
            Appearance vector of the AAM named by ``aam_fingerprint``.

        Returns
        -------
        label : str
            The class of highest score.
        scores : (n_classes,) float64 array
            Per-class scores in ``class_names`` order.

        Raises
        ------
        ValueError
            If ``c`` has the wrong shape or a non-finite entry.
        """
        c = np.asarray(c, dtype=np.float64)
        if c.shape != (self.feature_dim,):
            raise ValueError(
                f"expected an appearance vector of shape ({self.feature_dim},), got {c.shape}"
            )
        if not np.isfinite(c).all():
            raise ValueError("the appearance vector has a non-finite entry")
        scores = self.model.scores(c[None, :])[0]
        return self.class_names[int(np.argmax(scores))], scores

    def check_aam(self, fingerprint: str) -> None:
        """Refuse an AAM other than the one the classifier was trained on.

        Raises
        ------
        AAMMismatchError
            If ``fingerprint`` differs from :attr:`aam_fingerprint`.
        """
        if fingerprint != self.aam_fingerprint:
            raise AAMMismatchError(
                f"this expression classifier was trained on appearance vectors of AAM "
                f"{self.aam_fingerprint!r}, not of AAM {fingerprint!r}: retrain it for this AAM"
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
        }

    def save(self, path: str | Path) -> Path:
        """Write the classifier to ``path`` (``.npz`` is appended if missing); return the path."""
        path = Path(path)
        if path.suffix != ".npz":
            path = path.with_name(path.name + ".npz")
        header = np.frombuffer(json.dumps(self.header()).encode("utf-8"), dtype=np.uint8)
        arrays = {k: np.asarray(v) for k, v in self.model.to_arrays().items()}
        np.savez(path, **{_HEADER: header}, **arrays)
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
        try:
            if kind == "lda_mahalanobis":
                model: Model = MahalanobisModel.from_arrays(arrays)
            else:
                model = SVMModel.from_arrays(arrays, kind.removeprefix("svm_"), len(names))
            classifier = cls(kind, names, header["aam_fingerprint"], model, header["info"])
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
                            "retrain or convert the classifier", ClassifierFileError)
    missing = {"kind", "class_names", "feature_dim", "aam_fingerprint", "info"} - set(header)
    if missing:
        raise ClassifierFileError(f"{path}: header lacks {', '.join(sorted(missing))}")
    if header["kind"] not in KINDS:
        raise ClassifierFileError(f"{path}: unknown classifier kind {header['kind']!r}")
    return header
