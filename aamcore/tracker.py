"""The one-call Python API: a face tracker that returns one result object per frame.

::

    from aamcore import FaceTracker

    tracker = FaceTracker()                      # the default model, trained on first use
    for result in tracker.process_video("clip.mp4"):
        if result.success:
            print(result.frame_index, result.yaw_deg, result.landmarks[30])

It is the stack without the bus: the same fitter, tracker, head-pose
estimator, smoothing and expression recogniser the services run, so the two
give the same numbers on the same frames.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from aamcore import defaults
from aamcore.detection.haar import HaarFaceDetector
from aamcore.expression.classifier_file import ExpressionClassifier
from aamcore.expression.recogniser import ExpressionRecogniser, Recognition
from aamcore.fitting.config import FITTER, FitterConfig
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.fitting.multi import MultiTracker, NewFaces, TrackedFace
from aamcore.fitting.result import AAMFit, LandmarkFit, appearance_of
from aamcore.fitting.search import SearchSchedule
from aamcore.fitting.tracker import Refit
from aamcore.io.video import FALLBACK_FPS, frame_rate
from aamcore.model.similarity import Similarity
from aamcore.pose import IntrinsicsError, PoseError
from aamcore.pose.estimator import Cameras, HeadPose, HeadPoseEstimator, HeadPoseTracker
from aamcore.profiles import profile_named
from aamcore.smoothing import LandmarkSmoother

"""Frame rate assumed for timestamps when :meth:`FaceTracker.process` is given none."""
NO_FACE = "no face"


@dataclass(frozen=True, eq=False)
class FaceResult:
    """What the tracker found in one frame.

    Attributes
    ----------
    frame_index : int
    timestamp : float
        Seconds (the frame's, or ``frame_index / 30``).
    success : bool
        A face was found and its fit passed the failure test.
    confidence : float
        How good the fit is, 0 to 1 (0 without a face or for a failed fit): from
        the learned quality score with the default method
        (:meth:`~aamcore.fitting.failure.QualityTest.confidence`), from the
        appearance's chi-square with the AAM methods.
    landmarks : (N, 2) float64 array
        Landmarks in pixels; ``(0, 2)`` without a face.
    similarity : Similarity or None
        The 2D placement of the model frame in the image.
    rotation : (3, 3) array or None
        Head rotation, model to camera (``X_cam = R X_model + T``).
    translation_mm : (3,) array or None
        Head model origin in camera coordinates, millimetres.
    roll_deg, pitch_deg, yaw_deg : float
        The rotation as angles (NaN without a pose).
    pose_reliable : bool
    expression : str or None
        None when no classifier was given, or the face was not classified
        (``expression_reason`` says why).
    expression_scores : dict of str to float
    reason : str
        Why there is no face, the fit failed, there is no pose or the pose is
        unreliable; empty otherwise.
    expression_reason : str
        Why there is no expression (``"<key>: <details>"``: no face, face in
        profile, learning the face's reference, ...); empty with one or
        without a classifier.
    occluded : (N,) bool array or None
        Per landmark, whether its part of the face is covered (from the AAM's
        texture residual); None where it was not judged (no face, a failed fit,
        a model without an occlusion part).
    face_id : int
        Which face (:class:`~aamcore.fitting.multi.TrackedFace`): the same while it is
        tracked; -1 for a frame without a tracked face (no face, or a failed fit).
    """

    frame_index: int
    timestamp: float
    success: bool
    confidence: float
    landmarks: np.ndarray
    similarity: Similarity | None = None
    rotation: np.ndarray | None = None
    translation_mm: np.ndarray | None = None
    roll_deg: float = math.nan
    pitch_deg: float = math.nan
    yaw_deg: float = math.nan
    pose_reliable: bool = False
    expression: str | None = None
    expression_scores: dict[str, float] = field(default_factory=dict)
    reason: str = ""
    expression_reason: str = ""
    occluded: np.ndarray | None = None
    face_id: int = -1

    def to_dict(self) -> dict[str, Any]:
        """The result as plain JSON-ready data (lists, floats, None for what is missing)."""

        def num(x: float) -> float | None:
            return None if math.isnan(x) else float(x)

        sim = self.similarity
        return {
            "frame": self.frame_index, "face_id": self.face_id, "timestamp": self.timestamp,
            "success": self.success,
            "confidence": float(self.confidence), "landmarks": self.landmarks.tolist(),
            "similarity": None if sim is None else [sim.a, sim.b, sim.tx, sim.ty],
            "rotation": None if self.rotation is None else self.rotation.tolist(),
            "translation_mm": (None if self.translation_mm is None
                               else self.translation_mm.tolist()),
            "roll_deg": num(self.roll_deg), "pitch_deg": num(self.pitch_deg),
            "yaw_deg": num(self.yaw_deg), "pose_reliable": self.pose_reliable,
            "expression": self.expression, "expression_scores": dict(self.expression_scores),
            "reason": self.reason, "expression_reason": self.expression_reason,
            "occluded": None if self.occluded is None else [bool(v) for v in self.occluded],
        }


def _model(model: str | Path | FittingModel | None) -> tuple[FittingModel, Path | None]:
    """The fitting model and its file (None when given loaded)."""
    if isinstance(model, FittingModel):
        return model, None
    if model is None:
        from aamcore.fitting.training.prepare import default_model_path

        model = default_model_path()
    return FittingModel.load(model), Path(model)


def _recogniser(classifier: str | Path | ExpressionClassifier | None, model: FittingModel,
                path: Path | None, algorithm: str, smooth: int, hold: int = 0
                ) -> ExpressionRecogniser | None:
    """The expression recogniser of a classifier for the fits of ``model`` by ``algorithm``,
    or None without one.

    Raises
    ------
    ClassifierFileError, AAMMismatchError
        For an unreadable classifier file, or a classifier made for other fits.
    """
    if classifier is None:
        return None
    if not isinstance(classifier, ExpressionClassifier):
        classifier = ExpressionClassifier.load(classifier)
    if path is not None:
        from aamcore.expression.training import check_made_for, model_fingerprint

        check_made_for(classifier, model_fingerprint(path), algorithm)
    aam = model.aam
    classifier.check_fit(aam.scheme.name, aam.scheme.n_points, aam.n_appearance)
    return ExpressionRecogniser(classifier, smooth, hold=hold)


class FaceTracker:
    """Landmarks, head pose and expression of the face in each frame of a video.

    Parameters
    ----------
    model : path or FittingModel, optional
        The fitting model; the profile's (or the default) model, trained and cached on
        first use, if None.
    classifier : path, ExpressionClassifier or False, optional
        Expression classifier for the model's fits
        (:func:`aamcore.expression.training.classifier_path` makes one). None: the
        profile's classifier where a profile is named (trained and cached on first
        use), else no expression; False: no expression. A classifier made for other
        fits (another model or algorithm) is refused
        (:class:`~aamcore.expression.AAMMismatchError`).
    camera : str or float, optional
        A calibration file, or a horizontal field of view in degrees
        (:data:`aamcore.defaults.FOV_DEG` if None).
    profile : str, optional
        A pipeline of :data:`aamcore.profiles.PROFILES` (``"default"``, ``"thesis"``):
        its model, fitting, head-pose estimator and expression features, unless given
        here.
    algorithm, failure_test : str, optional
        As :class:`~aamcore.fitting.fitter.Fitter` takes them (the profile's, or
        :data:`~aamcore.fitting.config.FITTER`'s).
    smoothing : bool
        Smooth landmarks and pose over time (One Euro filter, :mod:`aamcore.smoothing`).
    pose_estimator : str, optional
        One of :data:`aamcore.defaults.POSE_ESTIMATORS`
        (:class:`~aamcore.pose.estimator.HeadPoseEstimator`).
    expression_smooth : int
        Average the expression probabilities over this many classified frames (the
        expression service's ``--smooth``; 1: none).
    expression_hold : int
        Classified frames a new expression label must lead before it replaces the one
        shown (the expression service's ``--hold``, on in the stack,
        :data:`~aamcore.expression.recogniser.STACK_HOLD`; 0: none).
    fitter : FitterConfig, optional
        The whole fitting configuration (``algorithm`` and ``failure_test`` override it).
    search : SearchSchedule, optional
        Which frames without a face are searched (the stack's default; for offline
        work where time is no object, :meth:`SearchSchedule.every_frame`).
    refit : Refit, optional
        When a tracked frame is also fitted afresh from the mean face placed on its
        landmarks (:data:`aamcore.fitting.tracker.DEFAULT_REFIT`, the stack's; ``NEVER``:
        tracking only).
    """

    def __init__(self, model: str | Path | FittingModel | None = None,
                 classifier: str | Path | ExpressionClassifier | bool | None = None,
                 camera: str | float | None = None, *, profile: str | None = None,
                 algorithm: str | None = None, failure_test: str | None = None,
                 smoothing: bool = False, pose_estimator: str | None = None,
                 expression_smooth: int = 1, expression_hold: int = 0,
                 fitter: FitterConfig | None = None,
                 search: SearchSchedule | None = None, refit: Refit | None = None,
                 max_faces: int = 1, new_faces: NewFaces | None = None) -> None:
        chosen = profile_named(profile) if profile else None
        config = fitter or (chosen.fitter if chosen else FITTER)
        given = {"algorithm": algorithm, "failure_test": failure_test}
        config = replace(config, **{k: v for k, v in given.items() if v is not None})
        self.config = config
        self.profile = chosen
        if model is None and chosen is not None:
            model = chosen.model_path()
        self.model, path = _model(model)
        if classifier is None and chosen is not None and path is not None:
            classifier = chosen.classifier_path(path, config.algorithm)
        self.expression = _recogniser(classifier or None, self.model, path,  # type: ignore
                                      config.algorithm, expression_smooth, expression_hold)
        """The first face's expression recogniser (None without a classifier); each face
        has its own, made like it."""
        self.tracker = MultiTracker(Fitter.from_config(self.model, config), HaarFaceDetector(),
                                    max_faces, search, refit, new_faces)
        calibration = camera if isinstance(camera, str | Path) else None
        fov = float(camera) if isinstance(camera, int | float) else defaults.FOV_DEG
        self._cameras = Cameras(fov, str(calibration) if calibration else None)
        self._method = pose_estimator or (chosen.pose_estimator if chosen
                                          else defaults.POSE_ESTIMATOR)
        self._smoothing = smoothing
        self._expression_args = (expression_smooth, expression_hold)
        self._faces: dict[int, _FaceState] = {}
        self._state(0)  # a camera file that cannot be read is refused here, not at a face
        self.frames = 0

    @property
    def pose_method(self) -> str:
        """The head-pose estimator's method (:data:`aamcore.defaults.POSE_ESTIMATORS`)."""
        return self._method

    @property
    def class_names(self) -> tuple[str, ...]:
        """The expression classes (none without a classifier)."""
        return () if self.expression is None else tuple(self.expression.classifier.class_names)

    def _state(self, face_id: int) -> _FaceState:
        """The smoothing, pose and expression state of a face (with one face, the one state
        whatever its id: a face found again keeps its expression reference, as before)."""
        key = face_id if self.tracker.max_faces > 1 else 0
        state = self._faces.get(key)
        if state is None:
            recogniser = self.expression
            if recogniser is not None and any(other.expression is recogniser
                                              for other in self._faces.values()):
                smooth, hold = self._expression_args
                recogniser = ExpressionRecogniser(recogniser.classifier, smooth, hold=hold)
            pose = HeadPoseTracker(HeadPoseEstimator(self._cameras, method=self._method),
                                   self._smoothing)
            state = _FaceState(pose, LandmarkSmoother() if self._smoothing else None, recogniser)
            self._faces[key] = state
        return state

    def reset(self) -> None:
        """Forget the faces: the next frame starts from a detection."""
        self.tracker.reset()
        for state in self._faces.values():
            state.reset()
        if self.tracker.max_faces > 1:
            self._faces.clear()

    def process(self, frame: np.ndarray, timestamp: float | None = None) -> FaceResult:
        """The result for one frame (BGR or grey uint8), at ``timestamp`` seconds: of its
        first face by id (:meth:`process_faces` gives every face's)."""
        return self.process_faces(frame, timestamp)[0]

    def process_faces(self, frame: np.ndarray, timestamp: float | None = None
                      ) -> list[FaceResult]:
        """One result per face tracked in a frame, by ``face_id``; one result without a
        face (``face_id`` -1, a failed fit's landmarks if there was one) when none is."""
        index = self.frames
        self.frames += 1
        t = index / FALLBACK_FPS if timestamp is None else float(timestamp)
        tracked, failed = self.tracker.track(frame)
        results = [self._result(index, t, frame, face.fit, self._state(face.face_id),
                                face.face_id) for face in tracked]
        self._forget_gone(tracked)
        if results:
            return results
        found = None
        if self.tracker.max_faces == 1:
            state = self._state(-1)
            if failed is not None:
                return [self._result(index, t, frame, failed, state, -1)]
            found = state.lost(index, frame)
        return [joined_result(index, t, np.zeros((0, 2)), False, 0.0, None, NO_FACE, None,
                              None, None, (), None, found.reason if found else "")]

    def _forget_gone(self, tracked: list[TrackedFace]) -> None:
        """Drop the state of faces no longer tracked (several faces only: their ids are not
        given again once the regain window has passed)."""
        if self.tracker.max_faces == 1:
            return
        here = {face.face_id for face in tracked}
        regainable = {g.face_id for g in self.tracker.ids.lost}
        for key in [k for k in self._faces if k not in here]:
            if key in regainable:
                self._faces[key].lost()
            else:
                self._faces.pop(key).reset()

    def _result(self, index: int, t: float, frame: np.ndarray, fit: LandmarkFit,
                state: _FaceState, face_id: int) -> FaceResult:
        points = fit.points if state.landmarks is None else state.landmarks.smoothed(
            fit, t).points  # type: ignore[union-attr]  (None only for no fit)
        try:
            pose, why = state.pose.update(points, frame.shape[1], frame.shape[0], t,
                                          fit.failed), ""
        except (PoseError, IntrinsicsError) as exc:
            pose, why = None, f"no pose: {exc}"
        expression = state.recognise(index, frame, fit, points, self.model.aam.scheme.name)
        return replace(result_of(index, t, fit, points, pose, why, expression), face_id=face_id)

    def process_video(self, path: str | Path) -> Iterator[FaceResult]:
        """The result of every frame of a video file (its first face's), timestamps from its
        frame rate.

        Raises
        ------
        OSError
            When the file cannot be opened (raised at the first ``next``).
        """
        for faces in self.process_video_faces(path):
            yield faces[0]

    def process_video_faces(self, path: str | Path) -> Iterator[list[FaceResult]]:
        """Every frame's results (:meth:`process_faces`), timestamps from its frame rate.

        Raises
        ------
        OSError
            When the file cannot be opened (raised at the first ``next``).
        """
        import cv2

        capture = cv2.VideoCapture(str(path))
        if not capture.isOpened():
            raise OSError(f"{path}: not a video OpenCV can open")
        fps = frame_rate(capture)
        self.reset()
        self.frames = 0
        try:
            while True:
                ok, frame = capture.read()
                if not ok:
                    return
                yield self.process_faces(frame, self.frames / fps)
        finally:
            capture.release()


@dataclass(eq=False)
class _FaceState:
    """What the tracker keeps of one face between frames."""

    pose: HeadPoseTracker
    landmarks: LandmarkSmoother | None
    expression: ExpressionRecogniser | None

    def reset(self) -> None:
        self.pose.reset()
        for part in (self.landmarks, self.expression):
            if part is not None:
                part.reset()

    def lost(self, index: int = -1, frame: np.ndarray | None = None) -> Recognition | None:
        """The face is not in this frame: its pose restarts; with ``frame``, the expression
        recogniser hears of it (as the expression service hears of a frame without a
        face)."""
        self.pose.reset()
        if self.landmarks is not None:
            self.landmarks.reset()
        if self.expression is None or frame is None:
            return None
        return self.expression.recognise(index, frame, None, None, True, NO_FACE)

    def recognise(self, index: int, frame: np.ndarray, fit: LandmarkFit,
                  points: np.ndarray, scheme: str) -> Recognition | None:
        """The expression of frame ``index`` from its fit and the landmarks the result
        carries (smoothed or not), as the expression service computes it from the frame
        and the ``Fit`` message; None without a classifier."""
        if self.expression is None:
            return None
        occluded = fit.occluded if isinstance(fit, AAMFit) else None
        return self.expression.recognise(index, frame, points, appearance_of(fit), fit.failed,
                                         fit.reason, scheme, occluded)


@dataclass(frozen=True)
class PoseParts:
    """The head pose of one frame as a result carries it (from the library's estimate or a
    ``pose`` message)."""

    rotation: np.ndarray
    translation_mm: np.ndarray
    roll_deg: float
    pitch_deg: float
    yaw_deg: float
    reliable: bool
    reason: str = ""


def joined_result(index: int, t: float, points: np.ndarray, success: bool, confidence: float,
                  similarity: Similarity | None, reason: str, occluded: np.ndarray | None,
                  pose: PoseParts | None, label: str | None, class_names: tuple[str, ...],
                  scores: np.ndarray | None, expression_reason: str) -> FaceResult:
    """The one join of a frame's fit, pose and expression into a :class:`FaceResult`, for the
    library (:func:`result_of`) and for a recording's messages (``aamtrack export``).

    Without landmarks the frame has no face (``reason`` or "no face"); a pose is reliable
    only on a good fit; the fit's reason comes before the pose's; scores come with a label.
    """
    if len(points) == 0:
        return FaceResult(index, t, False, 0.0, np.zeros((0, 2)), reason=reason or NO_FACE,
                          expression_reason=expression_reason)
    named = ({} if label is None or scores is None
             else dict(zip(class_names, map(float, scores), strict=True)))
    common: dict[str, Any] = dict(similarity=similarity, expression=label,
                                  expression_scores=named, expression_reason=expression_reason,
                                  occluded=occluded)
    if pose is None:
        return FaceResult(index, t, success, confidence, points, reason=reason, **common)
    return FaceResult(index, t, success, confidence, points, rotation=pose.rotation,
                      translation_mm=pose.translation_mm, roll_deg=float(pose.roll_deg),
                      pitch_deg=float(pose.pitch_deg), yaw_deg=float(pose.yaw_deg),
                      pose_reliable=bool(pose.reliable and success),
                      reason=reason or pose.reason, **common)


def result_of(index: int, t: float, fit: LandmarkFit, points: np.ndarray,
              pose: HeadPose | None, why: str, expression: Recognition | None) -> FaceResult:
    """The library's :class:`FaceResult` of a frame's parts (:func:`joined_result`)."""
    occluded = fit.occluded if isinstance(fit, AAMFit) and not fit.failed else None
    parts = None
    if pose is not None:
        est = pose.estimate
        roll, pitch, yaw = est.rpy
        parts = PoseParts(est.R, est.T, roll, pitch, yaw, est.reliable, pose.reason)
    label, names, scores, expression_reason = None, (), None, ""
    if expression is not None:
        label, names, scores = expression.label, expression.class_names, expression.scores
        expression_reason = expression.reason
    return joined_result(index, t, points, fit.ok, fit.confidence, fit.similarity,
                         fit.reason or why, occluded, parts, label, names, scores,
                         expression_reason)
