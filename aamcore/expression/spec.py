"""What an expression classifier needs besides its numbers: features, reference, quality limits.

A :class:`PipelineSpec` is saved in every classifier file
(:mod:`.classifier_file`), so that the library and the expression service
compute exactly the features the classifier was trained on. Its parts:

- :class:`FeatureConfig`: which feature blocks (``hog``: HOG patches around
  the inner landmarks of the canonical crop; ``shape``: the 68 landmarks in the
  canonical frame; ``appearance``: the fitter's ``c``), with the crop and HOG
  settings;
- whether the vectors are taken relative to the stream's reference, and that
  reference's settings (:class:`~aamcore.expression.reference.NeutralReference`);
- :class:`QualityLimits`: the thresholds of the quality gate (:mod:`.quality`);
- the shape template of the training faces, for the gate.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from aamcore.expression.crop import INNER_POINTS, N_LANDMARKS, SCHEME
from aamcore.expression.reference import NeutralReference

FEATURE_VERSION = 2
"""Bump when the feature computation changes: classifiers of another version are refused."""
BLOCK_NAMES: tuple[str, ...] = ("hog", "shape", "appearance")
STREAM_REFERENCE: dict[str, float] = {"window": 120, "stride": 5, "min_count": 10,
                                       "min_neutral": 0.5}
"""The stream's reference: the median of the last 120 kept vectors, one in 5 of the
classifiable frames the person-independent model calls neutral with probability 0.5 or
more (20 s of them at 30 fps); used once it holds 10 (from the 46th such frame, 1.5 s at
30 fps). The relative model learns from the median of each person's faces that look
neutral, what this becomes."""


@dataclass(frozen=True)
class FeatureConfig:
    """How the feature blocks are computed.

    Attributes
    ----------
    blocks : tuple of str
        The blocks of the feature vector, in order; names from :data:`BLOCK_NAMES`.
    crop_size : int
        Side of the canonical face crop, pixels.
    eye_distance : float
        Distance between the eye centres in the crop, pixels.
    eye_row : float
        Row of the eye centres in the crop, pixels.
    equalise : bool
        Histogram-equalise the crop before the HOG.
    hog_points : tuple of int
        Landmarks around which HOG patches are taken.
    hog_half : int
        Half side of a HOG patch in crop pixels (the patch is ``2 * hog_half`` wide).
    hog_cells : int
        The patch is split into ``hog_cells x hog_cells`` cells.
    hog_bins : int
        Unsigned orientation bins per cell.
    """

    blocks: tuple[str, ...] = ("hog", "shape")
    crop_size: int = 128
    eye_distance: float = 48.0
    eye_row: float = 48.0
    equalise: bool = True
    hog_points: tuple[int, ...] = INNER_POINTS
    hog_half: int = 12
    hog_cells: int = 2
    hog_bins: int = 9

    def __post_init__(self) -> None:
        unknown = sorted(set(self.blocks) - set(BLOCK_NAMES))
        if unknown or not self.blocks or len(set(self.blocks)) != len(self.blocks):
            raise ValueError(f"blocks {self.blocks} must be distinct names from {BLOCK_NAMES}")
        if not all(0 <= i < N_LANDMARKS for i in self.hog_points):
            raise ValueError(f"hog_points must be landmark indices below {N_LANDMARKS}")
        if self.hog_half < 2 or self.hog_cells < 1 or self.hog_bins < 2:
            raise ValueError("hog_half >= 2, hog_cells >= 1 and hog_bins >= 2 are needed")
        if (2 * self.hog_half) % self.hog_cells:
            raise ValueError("2 * hog_half must be a multiple of hog_cells")

    def block_dims(self, appearance_dim: int) -> dict[str, int]:
        """Length of each block of :attr:`blocks`, given the AAM's appearance length."""
        dims = {
            "hog": len(self.hog_points) * self.hog_cells**2 * self.hog_bins,
            "shape": 2 * N_LANDMARKS,
            "appearance": appearance_dim,
        }
        return {name: dims[name] for name in self.blocks}

    def with_blocks(self, blocks: tuple[str, ...]) -> FeatureConfig:
        """The same settings with other blocks."""
        return FeatureConfig.from_json(self.to_json() | {"blocks": list(blocks)})

    def to_json(self) -> dict[str, Any]:
        """A JSON-serialisable dict (lists for the tuples)."""
        out = asdict(self)
        return {k: list(v) if isinstance(v, tuple) else v for k, v in out.items()}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> FeatureConfig:
        """Inverse of :meth:`to_json`; raises ValueError on unknown or bad entries."""
        unknown = sorted(set(data) - set(cls.__dataclass_fields__))
        if unknown:
            raise ValueError(f"unknown feature settings {unknown}")
        values = {k: tuple(v) if isinstance(v, list) else v for k, v in data.items()}
        return cls(**values)

    def __str__(self) -> str:
        return json.dumps(self.to_json(), sort_keys=True)


@dataclass(frozen=True)
class QualityLimits:
    """Thresholds of the quality gate (:func:`aamcore.expression.quality.landmark_problem`).

    Attributes
    ----------
    min_eye_distance : float
        Smallest distance between the eye centres, frame pixels.
    max_outside : float
        Largest fraction of landmarks outside the frame.
    max_roll_deg : float
        Largest angle of the line through the eye centres.
    max_yaw_deg : float
        Largest head turn, as estimated by
        :func:`~aamcore.expression.crop.approximate_yaw_deg`.
    min_symmetry : float
        Smallest :func:`~aamcore.expression.hog_patches.mirror_symmetry` of the
        face: a turned face onto which the fitter forced a frontal shape looks
        unlike its mirror image.
    max_shape_deviation : float
        Largest RMS distance of the canonical shape from the classifier's
        template shape, in eye distances (checked only when there is a template).
    max_covered : float
        Largest share of the inner landmarks (brows, eyes, nose, mouth) the fit
        flags occluded (the AAM's texture residual, e.g. a hand over the mouth):
        a covered face's features are the cover's (checked only with flags).
    min_sharpness : float
        Smallest :func:`~aamcore.expression.quality.sharpness` of the face (the variance of
        the Laplacian of its equalised crop around the inner landmarks): a blurred face (out
        of focus, moving, or too small and enlarged) loses the texture of its expression.
        The limit follows a rule on the training people alone: it refuses 1 % of their
        faces as they are, half the 2 % of sharp faces the gate may refuse (the 1st
        percentile of the 3,351 training faces of the Taiwanese and LFW sets that the
        stack fits, 71.9: ``python -m bench expression-degraded`` prints it; the Taiwanese
        faces are all far above it, the LFW ones are small JPEGs). On the held-out people
        of the same bench it refuses none of 289 sharp faces and 64 % of those blurred by
        a Gaussian of 2 crop pixels (a twenty-fourth of the eye distance), whose labels are
        right 53.8 % of the time against 70.5 % sharp (the classifier of training version
        12); of those blurred by 3 or more none is labelled. Training faces are learned from
        blurred or not.
    """

    min_eye_distance: float = 16.0
    max_outside: float = 0.1
    max_roll_deg: float = 40.0
    max_yaw_deg: float = 35.0
    min_symmetry: float = 0.72
    max_shape_deviation: float = 0.5
    max_covered: float = 0.2
    min_sharpness: float = 72.0


@dataclass(frozen=True, eq=False)
class PipelineSpec:
    """Everything the expression stage needs besides the classifier's numbers.

    Attributes
    ----------
    features : FeatureConfig
    appearance_dim : int
        Length of the fitter's appearance vector ``c`` (its AAM's combined modes).
    relative : bool
        Classify ``features - reference`` (True) or the features themselves.
    reference : dict
        :class:`NeutralReference` settings for a stream (``window``, ``stride``,
        ``min_count``).
    quality : QualityLimits
    template : (68, 2) float64 array or None
        Mean canonical shape of the training faces, for the quality gate.
    scheme : str
        Landmark scheme of the fitter (``"ibug68"``).
    feature_version : int
        :data:`FEATURE_VERSION` of the code that computed the training features.
    """

    features: FeatureConfig
    appearance_dim: int
    relative: bool = True
    reference: dict[str, Any] = field(default_factory=lambda: dict(STREAM_REFERENCE))
    quality: QualityLimits = QualityLimits()
    template: np.ndarray | None = None
    scheme: str = SCHEME
    feature_version: int = FEATURE_VERSION

    def __post_init__(self) -> None:
        if self.template is not None and np.shape(self.template) != (N_LANDMARKS, 2):
            raise ValueError(f"template must be ({N_LANDMARKS}, 2), got {np.shape(self.template)}")
        if self.appearance_dim < 0:
            raise ValueError(f"appearance_dim must be >= 0, got {self.appearance_dim}")
        NeutralReference(**self.reference)  # raises ValueError on bad settings

    @property
    def block_dims(self) -> dict[str, int]:
        """Length of each block, in vector order."""
        return self.features.block_dims(self.appearance_dim)

    @property
    def feature_dim(self) -> int:
        """Length d of the feature vectors."""
        return sum(self.block_dims.values())

    def new_reference(self) -> NeutralReference:
        """An empty :class:`NeutralReference` with the stream settings."""
        return NeutralReference(**self.reference)

    def to_json(self) -> dict[str, Any]:
        """JSON-serialisable settings (the template is stored as an array, not here)."""
        return {
            "feature_version": self.feature_version,
            "scheme": self.scheme,
            "appearance_dim": self.appearance_dim,
            "relative": self.relative,
            "reference": dict(self.reference),
            "quality": asdict(self.quality),
            "features": self.features.to_json(),
            "has_template": self.template is not None,
        }

    @classmethod
    def from_json(cls, data: dict[str, Any], template: np.ndarray | None = None) -> PipelineSpec:
        """Inverse of :meth:`to_json`; KeyError, TypeError or ValueError when malformed."""
        if bool(data["has_template"]) != (template is not None):
            raise ValueError("the shape template is missing" if data["has_template"]
                             else "a shape template the settings do not announce")
        return cls(
            features=FeatureConfig.from_json(data["features"]),
            appearance_dim=int(data["appearance_dim"]),
            relative=bool(data["relative"]),
            reference=dict(data["reference"]),
            quality=QualityLimits(**data["quality"]),
            template=None if template is None else np.asarray(template, np.float64),
            scheme=str(data["scheme"]),
            feature_version=int(data["feature_version"]),
        )
