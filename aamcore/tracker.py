"""The one-call Python API: a face tracker that returns one result object per frame.

::

    from aamcore import FaceTracker

    tracker = FaceTracker()                      # the default model, trained on first use
    for result in tracker.process_video("clip.mp4"):
        if result.success:
            print(result.frame_index, result.yaw_deg, result.landmarks[30])

It is the stack in one process: the chain of the stages' operators
(:mod:`aamcore.operators`: fit, pose, expression) that the services wrap one each, so the
two give the same numbers on the same frames.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from aamcore.expression.classifier_file import ExpressionClassifier
from aamcore.face_result import NO_FACE, FaceResult, PoseParts, joined_result, result_of
from aamcore.fitting.model import FittingModel
from aamcore.io.video import FALLBACK_FPS, frame_rate
from aamcore.operators.detect import DetectOperator
from aamcore.operators.expression import ExpressionOperator, load_classifier
from aamcore.operators.faces import FrameRef
from aamcore.operators.fit import FitOperator
from aamcore.operators.options import PipelineOptions
from aamcore.operators.pose import PoseOperator
from aamcore.profiles import classifier_path, model_path, profile_named

__all__ = ["NO_FACE", "FaceResult", "FaceTracker", "PipelineOptions", "PoseParts",
           "joined_result", "result_of"]


def _options(options: PipelineOptions | None, profile: str | None, values: dict[str, Any]
             ) -> PipelineOptions:
    """The options asked for: ``options`` (or the profile's), the values named changed."""
    if not isinstance(options, PipelineOptions | None):
        raise TypeError(f"FaceTracker(options): a PipelineOptions, not "
                        f"{type(options).__name__} (give a model as model=...)")
    if options is None:
        options = profile_named(profile or "default").options
    return options.with_values(**values) if values else options


def _model(model: str | Path | FittingModel | None, options: PipelineOptions
           ) -> tuple[FittingModel, Path | None]:
    """The fitting model (the options', trained on first use, if None) and its file (None
    when given loaded)."""
    if isinstance(model, FittingModel):
        return model, None
    path = Path(model) if model is not None else model_path(options.model)
    return FittingModel.load(path), path


def _classifier(classifier: str | Path | ExpressionClassifier | bool | None,
                options: PipelineOptions, model: FittingModel, path: Path | None
                ) -> ExpressionClassifier | None:
    """The expression classifier (None: none), checked against the fits it will see.

    Raises
    ------
    ClassifierFileError, AAMMismatchError
        For an unreadable classifier file, or a classifier made for other fits.
    """
    if classifier is False or not options.expression.enabled:
        return None
    if classifier is None or classifier is True:
        if path is None and not options.expression.classifier:
            return None  # a loaded model: no classifier can be trained for it
        classifier = classifier_path(path, options)  # type: ignore[arg-type]
    classifier = load_classifier(classifier, path, options.fit.fitting.algorithm)
    aam = model.aam
    classifier.check_fit(aam.scheme.name, aam.scheme.n_points, aam.n_appearance)
    return classifier


class FaceTracker:
    """Landmarks, head pose and expression of the faces in each frame of a video.

    ``FaceTracker()`` runs what the stack runs by default: the default model and its
    expression classifier (trained and cached on first use), the default options
    (:data:`~aamcore.operators.options.PIPELINE`), smoothing and the label hold. It chains
    the stages' operators: :attr:`fit`, :attr:`pose` and :attr:`expression`.

    Parameters
    ----------
    options : PipelineOptions, optional
        Every choice of the pipeline (the profile's if None).
    model : path or FittingModel, optional
        The fitting model; the options' (``model_file``, or the recipe trained and cached
        on first use) if None.
    classifier : path, ExpressionClassifier or False, optional
        Expression classifier for the model's fits. None: the options' (``--classifier``,
        or the profile's trained and cached on first use for a model given by path; a
        loaded model gets none); False: no expression. A classifier made for other fits
        (another model or algorithm) is refused (:class:`~aamcore.expression.AAMMismatchError`).
    profile : str, optional
        A preset of :data:`aamcore.profiles.PROFILES` (``"default"`` if None), when
        ``options`` is not given.
    **values
        Values of the options by their flat names, the short form:
        ``FaceTracker(max_faces=2, landmark_smoothing=False, pose_fov=70)``
        (:meth:`~aamcore.settings.Settings.settings` lists them).

    Raises
    ------
    ConfigError
        For a value it does not know or does not accept, naming it and its stage.
    """

    def __init__(self, options: PipelineOptions | None = None, *,
                 model: str | Path | FittingModel | None = None,
                 classifier: str | Path | ExpressionClassifier | bool | None = None,
                 profile: str | None = None, **values: Any) -> None:
        options = _options(options, profile, values)
        self.options = options
        self.model, path = _model(model, options)
        classifier = _classifier(classifier, options, self.model, path)
        forget = options.fit.new_faces.forget_frames
        self.fit = FitOperator(self.model, options.fit, DetectOperator(options.detect))
        self.pose = PoseOperator(options.pose, forget)
        self.expression = (None if classifier is None
                           else ExpressionOperator(classifier, options.expression, forget))
        self.frames = 0

    def close(self) -> None:
        """End the GL warp worker if one was started (a later warp starts it again)."""
        self.fit.close()

    def __enter__(self) -> FaceTracker:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def camera_matrix(self, width: int, height: int) -> np.ndarray:
        """The camera matrix ``K`` (3, 3) the poses of ``width`` x ``height`` frames use."""
        return self.pose.cameras.at(width, height).K

    @property
    def class_names(self) -> tuple[str, ...]:
        """The expression classes (none without a classifier)."""
        return () if self.expression is None else self.expression.class_names

    def reset(self) -> None:
        """Forget the faces: the next frame starts from a detection."""
        for stage in (self.fit, self.pose, self.expression):
            if stage is not None:
                stage.reset()

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
        height, width = np.shape(frame)[:2] if np.ndim(frame) >= 2 else (0, 0)
        ref = FrameRef(index, t, width, height)
        faces = self.fit(frame, ref)
        poses = self.pose(ref, faces)
        expressions = ([None] * len(faces) if self.expression is None
                       else self.expression(ref, frame, faces))
        return [result_of(ref, *parts) for parts in zip(faces, poses, expressions, strict=True)]

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
