"""The quality gate and the feature blocks of one face, as every user computes them.

:func:`analyse_face` is the one function that turns a
:class:`~aamcore.expression.crop.FaceObservation` into feature blocks: the
expression pipeline of the library and the service calls it per frame
(:class:`~aamcore.expression.pipeline.ExpressionPipeline`), the training and
the benchmark call it per JAFFE face (:func:`observe`). The gate and the
features share one crop and one HOG computation.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from aamcore.expression.crop import (
    FaceFeatureError,
    FaceObservation,
    aligned_face,
    canonical_shape,
    check_landmarks,
)
from aamcore.expression.hog_patches import hog_block, hog_pair, patch_symmetry
from aamcore.expression.quality import blur_problem, landmark_gate, sharpness, symmetry_problem
from aamcore.expression.spec import FeatureConfig, QualityLimits

Blocks = dict[str, np.ndarray]


def analyse_face(
    observation: FaceObservation,
    config: FeatureConfig,
    limits: QualityLimits = QualityLimits(),
    template: np.ndarray | None = None,
    check: bool = True,
    appearance_dim: int | None = None,
    learn_blurred: bool = False,
) -> tuple[str, Blocks | None]:
    """The quality gate and the feature blocks of one face.

    Parameters
    ----------
    observation : FaceObservation
    config : FeatureConfig
        ``config.blocks`` names the blocks computed.
    limits : QualityLimits
    template : (68, 2) array, optional
        Canonical shape template of the gate (:func:`~aamcore.expression.quality.landmark_problem`).
    check : bool
        Run the gate (False: only compute the blocks, for a face known to pass).
    appearance_dim : int, optional
        A fit without an appearance (a failed regressor fit) gets this many zeros for it.
    learn_blurred : bool
        A face refused only as blurred gets its blocks beside the reason: the training learns
        from it (the sharpness check guards what is served, and a classifier that has seen a
        little blur reads a little blur better).

    Returns
    -------
    problem : str
        ``""`` or why the face is refused (``""`` when ``check`` is False).
    blocks : dict of str to 1-D float64 array, or None
        By name, in ``config.blocks`` order, lengths as
        :meth:`FeatureConfig.block_dims`; None when there is a problem (but for
        ``learn_blurred``).

    Raises
    ------
    FaceFeatureError
        With ``check`` False, for landmarks of the wrong shape, non-finite or
        with coincident eyes.
    """
    shape = None
    if check:
        problem, shape = landmark_gate(observation, limits, template)
        if problem:
            return problem, None
    points = observation.landmarks
    if shape is None:
        check_landmarks(points)
    problem, hog = "", None
    if check or "hog" in config.blocks:
        problem, hog = _hog(observation.image, points, config, limits if check else None,
                            learn_blurred, observation.occluded)
        if hog is None:
            return problem, None
    return problem, _blocks(config.blocks, hog, shape, points, observation.appearance,
                            appearance_dim)


def _blocks(names: tuple[str, ...], hog: np.ndarray | None, shape: np.ndarray | None,
            points: np.ndarray, appearance: np.ndarray, appearance_dim: int | None) -> Blocks:
    """The feature blocks by name: the HOG, the canonical shape (computed from ``points``
    where the gate gave none), the appearance (zeros where the fit has none)."""
    blocks: Blocks = {}
    for name in names:
        if name == "hog":
            assert hog is not None
            blocks[name] = hog
        elif name == "shape":
            blocks[name] = (canonical_shape(points) if shape is None else shape).ravel()
        elif appearance.size == 0 and appearance_dim is not None:
            blocks[name] = np.zeros(appearance_dim)
        else:
            blocks[name] = np.asarray(appearance, np.float64).copy()
    return blocks


def _hog(image: np.ndarray, points: np.ndarray, config: FeatureConfig,
         limits: QualityLimits | None, learn_blurred: bool = False,
         flags: np.ndarray | None = None) -> tuple[str, np.ndarray | None]:
    """With ``limits``, the gate's verdict on the face's sharpness, then its mirror symmetry
    (``""``: none checked or it passes; ``flags`` the fit's occlusion flags name a covered one),
    and the HOG block (P * cells^2 * bins,) of its canonical crop: None for a refused face
    (but a blurred one with ``learn_blurred``)."""
    crop, crop_points = aligned_face(image, points, config.crop_size, config.eye_distance,
                                     config.eye_row)
    equalised = cv2.equalizeHist(crop)
    if limits is None:
        return "", hog_block(equalised if config.equalise else crop, crop_points, config)
    blurred = blur_problem(sharpness(equalised, crop_points), limits)
    if blurred and not learn_blurred:
        return blurred, None
    own, mirrored = hog_pair(equalised, crop_points, config)
    symmetry = symmetry_problem(patch_symmetry(own, mirrored, len(config.hog_points)), limits,
                                flags)
    if symmetry:
        return blurred or symmetry, None
    return blurred, own if config.equalise else hog_block(crop, crop_points, config)


def face_problem(
    observation: FaceObservation,
    limits: QualityLimits = QualityLimits(),
    template: np.ndarray | None = None,
) -> str:
    """Why a face cannot be classified, or ``""``: the landmark checks, then the mirror
    symmetry of its HOG patches (default feature settings)."""
    return analyse_face(observation, FeatureConfig(blocks=("hog",)), limits, template)[0]


def feature_vector(blocks: Blocks, config: FeatureConfig) -> np.ndarray:
    """The blocks of :func:`analyse_face` side by side in ``config.blocks`` order; (d,)."""
    return np.concatenate([blocks[name] for name in config.blocks])


_NONE = np.zeros(0, np.intp)
_NONE.setflags(write=False)


def hidden_dims(occluded: np.ndarray | None, config: FeatureConfig, appearance_dim: int
                ) -> np.ndarray:
    """The dimensions (k,) of :func:`feature_vector` (with an appearance of
    ``appearance_dim``) that the HOG patches of the landmarks flagged ``occluded`` (68,) bool
    hold: what a hand or an object over them shows, not the face; none without flags or
    without HOG patches."""
    if occluded is None or not occluded.any() or "hog" not in config.blocks:
        return _NONE
    dims = config.block_dims(appearance_dim)
    start = sum(dims[name] for name in config.blocks[:config.blocks.index("hog")])
    size = config.hog_cells**2 * config.hog_bins
    patches = np.flatnonzero(np.asarray(occluded, bool)[list(config.hog_points)])
    return (start + patches[:, None] * size + np.arange(size)).ravel().astype(np.intp)


@dataclass
class Observed:
    """Feature blocks of many faces, as :func:`observe` computes them.

    Attributes
    ----------
    blocks : dict of str to (n, d_b) float64 array
        Every block asked for; rows of refused faces are zero (not those of
        :attr:`learnable` ones).
    problems : list of str
        Per face: ``""`` or why it was refused.
    learnable : (n,) bool array
        The faces with blocks: the classifiable ones and, observed with ``learn_blurred``,
        those refused only as blurred.
    """

    blocks: Blocks
    problems: list[str]
    learnable: np.ndarray

    @property
    def ok(self) -> np.ndarray:
        """Boolean mask (n,) of the classifiable faces."""
        return np.array([not p for p in self.problems], dtype=bool)

    def vectors(self, names: Sequence[str]) -> np.ndarray:
        """The blocks ``names`` side by side, shape (n, sum of their lengths)."""
        return np.hstack([self.blocks[name] for name in names])

    def dims(self, names: Sequence[str]) -> dict[str, int]:
        """The lengths of the blocks ``names``, in that order."""
        return {name: int(self.blocks[name].shape[1]) for name in names}


def observe(
    observations: Sequence[FaceObservation],
    config: FeatureConfig,
    limits: QualityLimits = QualityLimits(),
    template: np.ndarray | None = None,
    appearance_dim: int | None = None,
    learn_blurred: bool = False,
) -> Observed:
    """:func:`analyse_face` of each observation, gate included.

    Parameters
    ----------
    observations : sequence of n FaceObservation
    config : FeatureConfig
    limits, template
        Of the gate.
    appearance_dim, learn_blurred
        As :func:`analyse_face`.

    Returns
    -------
    Observed
    """
    rows: list[Blocks | None] = []
    problems = []
    for observation in observations:
        try:
            problem, blocks = analyse_face(observation, config, limits, template,
                                           appearance_dim=appearance_dim,
                                           learn_blurred=learn_blurred)
        except FaceFeatureError as exc:
            problem, blocks = f"no features: {exc}", None
        rows.append(blocks)
        problems.append(problem)
    good = [r for r in rows if r is not None]
    dims = {name: (good[0][name].size if good else 0) for name in config.blocks}
    out = {name: np.zeros((len(rows), dims[name])) for name in config.blocks}
    for i, r in enumerate(rows):
        if r is not None:
            for name in config.blocks:
                out[name][i] = r[name]
    return Observed(out, problems, np.array([r is not None for r in rows], dtype=bool))
