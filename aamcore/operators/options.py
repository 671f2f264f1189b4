"""Every choice of the pipeline in one typed tree, a part per stage, as MediaPipe's tasks
take one options object.

:class:`PipelineOptions` holds a part per stage, each the options of that stage's operator
(:mod:`aamcore.operators`): the fitting model (:class:`ModelOptions`), detection
(:class:`DetectOptions`), the fit stage (:class:`FitOptions`: how each frame is fitted,
refitted, searched, several faces, the warp, landmark smoothing), head pose
(:class:`PoseOptions`), expression (:class:`ExpressionOptions`) and the overlay
(:class:`OverlayOptions`). Each value is
declared once, with its default, help and range (:func:`aamcore.settings.setting`); its
flat name is its part's prefix and its own (``pose_fov``, ``refit_every``), its flag
``--`` and the flat name with dashes unless it says another (``--fov``).

From this one declaration the library (``FaceTracker(pose_fov=70)``), ``aamtrack run``,
``aamtrack track``, the stack file and each service take their options, help and checks
(:mod:`services.bus.options`); the profiles are named presets of it
(:mod:`aamcore.profiles`). A value the stage's operator needs is one
:func:`~aamcore.settings.setting` in its part, read by its operator: nothing else changes.

Light to import (the standard library and the parts' declarations): ``--help`` loads it.
"""

from __future__ import annotations

from dataclasses import dataclass

from aamcore import defaults
from aamcore.fitting.config import DEFAULT_REFIT, FITTER, FitterConfig, NewFaces, Refit
from aamcore.fitting.search import SearchSchedule
from aamcore.settings import ConfigError, Settings, group, setting

WARPS = ("auto", "gpu", "cpu")
"""Where the image warp runs (:class:`aamcore.fitting.warps.FitterWarp`)."""
UPDATE_METHODS = ("jacobian", "regression")
"""How the default model's update matrices are learned (as
:data:`aamcore.fitting.training.update.METHODS`, not imported: options load light)."""
EXPRESSION_FEATURES = ("deployed", "thesis")
"""Expression feature sets a classifier is trained on (:mod:`aamcore.expression.training`)."""
REFERENCE_RESET = 60
"""Frames without a classifiable face after which a face's expression reference is learned
afresh (:data:`aamcore.expression.pipeline.LOST_FRAMES_RESET`)."""


@dataclass(frozen=True)
class ModelOptions(Settings):
    """The fitting model: a file, or the profile's recipe trained and cached on first use."""

    STAGE = "model"

    file: str | None = setting(None, "fitting model file (default: the profile's model, "
                               "trained and cached on first use)", metavar="FILE",
                               flag="--model")
    limit: int = setting(0, "train the default model on the first N images only (small, for "
                         "tests)", low=0, metavar="N")
    images: int = setting(defaults.MODEL_UPDATE_IMAGES, "images for the default model's update "
                          "matrices", low=1, high=10000, metavar="N")
    update: str = setting("jacobian", "how the default model's update matrices are learned "
                          "(the fixed-Jacobian AAM's): jacobian (Algorithm 6) or regression "
                          "(Algorithm 5)", choices=UPDATE_METHODS)


@dataclass(frozen=True)
class DetectOptions(Settings):
    """The detect stage (:class:`aamcore.operators.detect.DetectOperator`): how Haar searches
    a frame."""

    STAGE = "detect"

    scale_factor: float = setting(defaults.DETECTOR["scale_factor"], "Haar scale step",
                                  low=1.01, high=2.0, metavar="F", flag="--scale-factor")
    min_neighbors: int = setting(defaults.DETECTOR["min_neighbors"], "Haar neighbours a "
                                 "detection needs", low=0, high=50, metavar="N",
                                 flag="--min-neighbors")
    min_size: int = setting(defaults.DETECTOR["min_size"][0], "smallest face side, pixels",
                            low=8, high=4096, metavar="PX", flag="--min-size")
    max_side: int = setting(defaults.DETECTOR["max_side"], "downscale frames to this longer "
                            "side before detecting (0: never)", low=0, high=4096,
                            metavar="PX", flag="--max-side")

    def __post_init__(self) -> None:
        super().__post_init__()
        if 0 < self.max_side < 32:
            raise ConfigError("max_side", self.max_side, "must be 0 (never) or 32 to 4096")


@dataclass(frozen=True)
class FitOptions(Settings):
    """The fit stage (:class:`aamcore.operators.fit.FitOperator`): how each frame is fitted
    with its appearance and occlusion flags, refitted, searched; several faces; the warp;
    landmark smoothing.

    Attributes
    ----------
    fitting : FitterConfig
        How each frame is fitted (flags without a prefix: ``--algorithm``).
    refit : Refit
        When a tracked frame is also fitted afresh from the mean face (``--refit-*``).
    search : SearchSchedule
        Which frames without a face are searched (``--search-*``).
    new_faces : NewFaces
        With several faces, how new ones are looked for and ids kept (``--new-faces-*``).
    max_faces, warp, landmark_smoothing
        As their help says.
    """

    STAGE = "fit"

    fitting: FitterConfig = group(FITTER, "how each frame is fitted")
    refit: Refit = group(DEFAULT_REFIT, "when a tracked frame is also fitted afresh", "refit")
    search: SearchSchedule = group(SearchSchedule(), "which frames without a face are "
                                   "searched", "search")
    new_faces: NewFaces = group(NewFaces(), "how new faces are looked for, ids kept and "
                                "faces forgotten", "new_faces")
    max_faces: int = setting(1, "track up to N faces per frame, each under its face_id "
                             "(1: the largest face)", low=1, high=defaults.MAX_FACES,
                             metavar="N")
    warp: str = setting("auto", "where the image warp runs: auto (the GPU worker thread on a "
                        "hardware GL renderer for a model of 20,000 reference pixels or more, "
                        "else the CPU), gpu (falls back to cpu) or cpu", choices=WARPS)
    landmark_smoothing: bool = setting(True, "smooth each face's landmarks over time (One "
                                       "Euro filter)")
    landmark_cutoff: float = setting(0.5, "the landmark smoothing's cut-off at rest, Hz: lower "
                                     "is steadier, and lags more", above=0, high=30,
                                     metavar="HZ")


@dataclass(frozen=True)
class PoseOptions(Settings):
    """The pose stage (:class:`aamcore.operators.pose.PoseOperator`): the estimator, the
    camera and pose smoothing."""

    STAGE = "pose"

    estimator: str = setting(defaults.POSE_ESTIMATOR, "head-pose estimator: contour (jaw "
                             "landmarks matched to the outline seen), posit (the thesis's, "
                             "without the jaw), contour+calib (contour with a head model "
                             "learned from the person)", choices=defaults.POSE_ESTIMATORS,
                             flag="--estimator")
    fov: float = setting(defaults.FOV_DEG, "assumed horizontal field of view, degrees",
                         low=1, high=179, metavar="DEG", flag="--fov")
    calibration: str | None = setting(None, "camera calibration file (.yaml, .xml, .json) "
                                      "instead of --fov", metavar="FILE", flag="--calibration")
    smoothing: bool = setting(True, "smooth each face's head pose over time (One Euro "
                              "filter)")

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.calibration is not None and self.fov != defaults.FOV_DEG:
            raise ConfigError("calibration", self.calibration,
                              "give --fov or --calibration, not both")


@dataclass(frozen=True)
class ExpressionOptions(Settings):
    """The expression stage (:class:`aamcore.operators.expression.ExpressionOperator`): the
    classifier, each face's reference, averaging and the label hold."""

    STAGE = "expression"

    enabled: bool = setting(True, "recognise expressions (--no-expression: none, nothing "
                            "trained for them)", flag="--expression")
    classifier: str | None = setting(None, "expression classifier file (default: the "
                                     "profile's for the model, trained and cached on first "
                                     "use)", metavar="FILE", flag="--classifier")
    features: str = setting("deployed", "the features the default classifier learns: "
                            "deployed (HOG + shape) or thesis (LDA + Mahalanobis on c)",
                            choices=EXPRESSION_FEATURES)
    reference_reset: int = setting(REFERENCE_RESET, "frames without a classifiable face after "
                                   "which a face's reference is learned afresh", low=1,
                                   high=100000, metavar="N")
    average: int = setting(1, "average the probabilities over the last N classified frames "
                           "(1: none)", low=1, high=1000, metavar="N")
    hold: int = setting(defaults.EXPRESSION_HOLD, "classified frames a new expression label "
                        "must lead before it is shown (0: none)", low=0, high=1000,
                        metavar="N")


@dataclass(frozen=True)
class OverlayOptions(Settings):
    """The overlay stage (:class:`aamcore.operators.overlay.OverlayOperator`)."""

    STAGE = "overlay"

    all_poses: bool = setting(False, "draw the glasses at unreliable poses too",
                              flag="--all-poses")
    hide_covered: bool = setting(True, "hide the glasses where a hand or an object covers "
                                 "the face (the fit's occluded landmarks)",
                                 flag="--hide-covered")


@dataclass(frozen=True)
class PipelineOptions(Settings):
    """Every choice of the pipeline, a part per stage.

    Attributes
    ----------
    model : ModelOptions
        ``--model``, ``--model-*``.
    detect : DetectOptions
        ``--scale-factor``, ``--min-neighbors``, ``--min-size``, ``--max-side``.
    fit : FitOptions
        Flags without a prefix (``--algorithm``, ``--refit-every``, ``--max-faces``).
    pose : PoseOptions
        ``--estimator``, ``--fov``, ``--calibration``, ``--pose-smoothing``.
    expression : ExpressionOptions
        ``--classifier``, ``--expression-*``.
    overlay : OverlayOptions
    """

    model: ModelOptions = group(ModelOptions(), "the fitting model", "model")
    detect: DetectOptions = group(DetectOptions(), "face detection", "detect")
    fit: FitOptions = group(FitOptions(), "landmarks: fitting, appearance, occlusion, "
                            "several faces, smoothing")
    pose: PoseOptions = group(PoseOptions(), "head pose: estimator, camera, smoothing", "pose")
    expression: ExpressionOptions = group(ExpressionOptions(), "expression: classifier, "
                                          "reference, averaging, label hold", "expression")
    overlay: OverlayOptions = group(OverlayOptions(), "the glasses overlay", "overlay")

    def smoothed(self, on: bool) -> PipelineOptions:
        """The same pipeline with every stage's smoothing over time on or off (landmarks,
        pose, the expression label's hold and averaging): ``--smooth``/``--no-smooth``."""
        if on:
            return self.with_values(landmark_smoothing=True, pose_smoothing=True)
        return self.with_values(landmark_smoothing=False, pose_smoothing=False,
                                expression_hold=0, expression_average=1)


PIPELINE = PipelineOptions()
"""The defaults."""
STAGES = ("model", "detect", "fit", "pose", "expression", "overlay")
"""The parts of :class:`PipelineOptions`, in pipeline order."""
