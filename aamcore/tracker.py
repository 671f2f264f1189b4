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

from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from aamcore import defaults
from aamcore.detection.haar import HaarFaceDetector
from aamcore.expression.classifier_file import ExpressionClassifier
from aamcore.expression.recogniser import ExpressionRecogniser, Recognition
from aamcore.face_result import NO_FACE, FaceResult, PoseParts, joined_result, result_of
from aamcore.fitting.config import FITTER, FitterConfig
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.fitting.multi import MultiTracker, NewFaces, TrackedFace
from aamcore.fitting.result import AAMFit, LandmarkFit, appearance_of
from aamcore.fitting.search import SearchSchedule
from aamcore.fitting.tracker import Refit
from aamcore.io.video import FALLBACK_FPS, frame_rate
from aamcore.pose import IntrinsicsError, PoseError
from aamcore.pose.estimator import Cameras, HeadPoseEstimator, HeadPoseTracker
from aamcore.profiles import profile_named
from aamcore.smoothing import LandmarkSmoother

__all__ = ["NO_FACE", "FaceResult", "FaceTracker", "PoseParts", "joined_result", "result_of"]


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
        self._faces: dict[int, _FaceState] = {}
        self._state(0)  # a camera file that cannot be read is refused here, not at a face
        self.frames = 0

    @property
    def pose_method(self) -> str:
        """The head-pose estimator's method (:data:`aamcore.defaults.POSE_ESTIMATORS`)."""
        return self._method

    def camera_matrix(self, width: int, height: int) -> np.ndarray:
        """The camera matrix ``K`` (3, 3) the poses of ``width`` x ``height`` frames use."""
        return self._cameras.at(width, height).K

    @property
    def class_names(self) -> tuple[str, ...]:
        """The expression classes (none without a classifier)."""
        return () if self.expression is None else tuple(self.expression.classifier.class_names)

    def _state(self, face_id: int) -> _FaceState:
        """The smoothing, pose and expression state of a face; face 0's also hears of the
        frames without a tracked face (a failed fit, ``face_id`` -1), as the services'
        first face does."""
        key = max(face_id, 0)
        state = self._faces.get(key)
        if state is None:
            recogniser = self.expression
            if recogniser is not None and any(other.expression is recogniser
                                              for other in self._faces.values()):
                recogniser = recogniser.fresh()
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
        for _, faces in self.process_video_frames(path):
            yield faces

    def process_video_frames(self, path: str | Path
                             ) -> Iterator[tuple[np.ndarray, list[FaceResult]]]:
        """Every frame of a video file with its results (:meth:`process_video_faces`)."""
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
                yield frame, self.process_faces(frame, self.frames / fps)
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
