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
from typing import Any

import numpy as np

from aamcore import defaults
from aamcore.detection.haar import HaarFaceDetector
from aamcore.expression.classifier_file import ExpressionClassifier
from aamcore.expression.recogniser import ExpressionRecogniser, Recognition
from aamcore.face_result import NO_FACE, FaceResult, PoseParts, joined_result, result_of
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.fitting.multi import MultiTracker, TrackedFace
from aamcore.fitting.result import AAMFit, LandmarkFit, appearance_of
from aamcore.fitting.warps import FitterWarp
from aamcore.io.video import FALLBACK_FPS, frame_rate
from aamcore.per_face import PerFace
from aamcore.pose import IntrinsicsError, PoseError
from aamcore.pose.estimator import Cameras, HeadPoseEstimator, HeadPoseTracker
from aamcore.profiles import Profile, profile_named
from aamcore.smoothing import LandmarkSmoother
from aamcore.tracker_config import TRACKER, TrackerConfig

__all__ = ["NO_FACE", "FaceResult", "FaceTracker", "PoseParts", "TrackerConfig",
           "joined_result", "result_of"]


def _model(model: str | Path | FittingModel | None, profile: Profile
           ) -> tuple[FittingModel, Path | None]:
    """The fitting model (the profile's, trained on first use, if None) and its file (None
    when given loaded)."""
    if isinstance(model, FittingModel):
        return model, None
    path = Path(model) if model is not None else profile.model_path()
    return FittingModel.load(path), path


def _recogniser(classifier: str | Path | ExpressionClassifier | None, model: FittingModel,
                path: Path | None, algorithm: str, smooth: int, hold: int
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


def _configured(config: TrackerConfig | str | Path | FittingModel | None,
                profile: Profile | None, settings: dict[str, Any]) -> TrackerConfig:
    """The configuration asked for: ``config`` (or the defaults with the profile's fitting),
    the values named in ``settings`` changed."""
    if not isinstance(config, TrackerConfig | None):
        raise TypeError(f"FaceTracker(config): a TrackerConfig, not {type(config).__name__} "
                        "(give a model as model=...)")
    if config is None:
        config = TRACKER if profile is None else TRACKER.replace(fitting=profile.fitter)
    return config.with_values(**settings) if settings else config


class FaceTracker:
    """Landmarks, head pose and expression of the faces in each frame of a video.

    ``FaceTracker()`` runs what the stack runs by default: the default model and its
    expression classifier (trained and cached on first use), the default tracking
    (:data:`~aamcore.tracker_config.TRACKER`), smoothing and the label hold.

    Parameters
    ----------
    config : TrackerConfig, optional
        How faces are tracked (:class:`~aamcore.tracker_config.TrackerConfig`; the
        defaults, with the profile's fitting, if None).
    model : path or FittingModel, optional
        The fitting model; the profile's model, trained and cached on first use, if None.
    classifier : path, ExpressionClassifier or False, optional
        Expression classifier for the model's fits. None: the profile's classifier for a
        model given by path (trained and cached on first use; a loaded model gets none);
        False: no expression. A classifier made for other fits (another model or
        algorithm) is refused (:class:`~aamcore.expression.AAMMismatchError`).
    camera : str or float, optional
        A calibration file, or a horizontal field of view in degrees
        (:data:`aamcore.defaults.FOV_DEG` if None).
    profile : str, optional
        A pipeline of :data:`aamcore.profiles.PROFILES` (``"default"`` if None): its model,
        fitting, head-pose estimator and expression features, unless given here.
    pose_estimator : str, optional
        One of :data:`aamcore.defaults.POSE_ESTIMATORS` (the profile's if None).
    expression_smooth : int
        Average the expression probabilities over this many classified frames (the
        expression service's ``--smooth``; 1: none).
    **settings
        Values of the configuration by their flat names, the short form:
        ``FaceTracker(max_faces=2, smoothing=False, refit_every=6)``
        (:meth:`~aamcore.settings.Settings.settings` lists them).

    Raises
    ------
    ConfigError
        For a setting it does not know or a value it does not accept, naming it.
    """

    def __init__(self, config: TrackerConfig | None = None, *,
                 model: str | Path | FittingModel | None = None,
                 classifier: str | Path | ExpressionClassifier | bool | None = None,
                 camera: str | float | None = None, profile: str | None = None,
                 pose_estimator: str | None = None, expression_smooth: int = 1,
                 **settings: Any) -> None:
        chosen = profile_named(profile or "default")
        config = _configured(config, profile_named(profile) if profile else None, settings)
        self.config = config
        self.profile = chosen
        self.model, path = _model(model, chosen)
        algorithm = config.fitting.algorithm
        if classifier is None and path is not None:
            classifier = chosen.classifier_path(path, algorithm)
        self.expression = _recogniser(classifier or None, self.model, path,  # type: ignore
                                      algorithm, expression_smooth, config.expression_hold)
        """The first face's expression recogniser (None without a classifier); each face
        has its own, made like it."""
        self.warp = FitterWarp(self.model.aam, config.warp)  # type: ignore[arg-type]
        """Where the fitter's warps run, started at the first warp (:meth:`close` ends it)."""
        self.tracker = MultiTracker.configured(Fitter(self.model, config.fitting, self.warp),
                                               config, HaarFaceDetector())
        calibration = camera if isinstance(camera, str | Path) else None
        fov = float(camera) if isinstance(camera, int | float) else defaults.FOV_DEG
        self._cameras = Cameras(fov, str(calibration) if calibration else None)
        self._method = pose_estimator or chosen.pose_estimator
        self._smoothing = config.smoothing
        # the first state holds the first recogniser; the camera file is read here
        self._faces = PerFace(lambda: self._new_state(fresh=True), _FaceState.reset,
                              self._new_state(fresh=False), config.new_faces.forget_frames)
        self.frames = 0

    def close(self) -> None:
        """End the GL warp worker if one was started (a later warp starts it again)."""
        self.warp.close()

    def __enter__(self) -> FaceTracker:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

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

    def _new_state(self, fresh: bool) -> _FaceState:
        """A face's smoothing, pose and expression state: with :attr:`expression` itself, or
        (``fresh``) a recogniser made like it."""
        recogniser = self.expression
        if recogniser is not None and fresh:
            recogniser = recogniser.fresh()
        pose = HeadPoseTracker(HeadPoseEstimator(self._cameras, method=self._method),
                               self._smoothing)
        return _FaceState(pose, LandmarkSmoother() if self._smoothing else None, recogniser)

    def _state(self, face_id: int) -> _FaceState:
        """The state of a face seen on the frame being processed; face 0's also hears of the
        frames without a tracked face (a failed fit, ``face_id`` -1), as the services'
        first face does."""
        return self._faces.of(max(face_id, 0), self.frames - 1)

    def reset(self) -> None:
        """Forget the faces: the next frame starts from a detection."""
        self.tracker.reset()
        self._faces.clear()
        self._faces.reset(self._faces.first)

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
        """The faces remembered but not in this frame restart their pose and smoothing when
        they come back (they are forgotten by :class:`~aamcore.per_face.PerFace`'s rule)."""
        if self.tracker.max_faces == 1:
            return
        here = {face.face_id for face in tracked}
        for key in self._faces.ids():
            if key not in here:
                self._faces.known(key).lost()  # type: ignore[union-attr]

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
