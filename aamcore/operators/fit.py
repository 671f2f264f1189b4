"""The fit stage: the landmarks of every face of a frame, with the AAM's appearance and
occlusion flags, tracked from frame to frame under stable ids and smoothed per face."""

from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np

from aamcore.detection.exposure import darkness
from aamcore.detection.haar import HaarFaceDetector
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.fitting.multi import MultiTracker
from aamcore.fitting.tracker import FaceDetector
from aamcore.fitting.warps import FitterWarp
from aamcore.operators.faces import NO_FACE, NOBODY, FaceFit, FrameRef
from aamcore.operators.options import PIPELINE, FitOptions
from aamcore.operators.per_face import PerFace
from aamcore.smoothing import LANDMARKS, LandmarkSmoother


class FitOperator:
    """Fit each frame's faces (:class:`~aamcore.fitting.multi.MultiTracker`), landmarks
    smoothed per face (:class:`~aamcore.smoothing.LandmarkSmoother`).

    Parameters
    ----------
    model : FittingModel
    options : FitOptions
    detector : FaceDetector, optional
        Where faces are searched for (Haar in this process by default; the fitter service
        asks the detector service).

    Attributes
    ----------
    warp : FitterWarp
        Where the warps run, started at the first warp (:meth:`close` ends it).
    warp_path : str
        The path the last frame's warps took (``none`` when nothing warped).
    """

    def __init__(self, model: FittingModel, options: FitOptions = PIPELINE.fit,
                 detector: FaceDetector | None = None) -> None:
        self.options = options
        self.model = model
        self.scheme = model.aam.scheme.name
        self.warp = FitterWarp(model.aam, options.warp)  # type: ignore[arg-type]
        self.fitter = Fitter(model, options.fitting, self.warp)
        self.tracker = MultiTracker.configured(self.fitter, options,
                                               detector or HaarFaceDetector())
        smoothing = replace(LANDMARKS, min_cutoff=options.landmark_cutoff)
        self.faces = PerFace(lambda: LandmarkSmoother(smoothing), LandmarkSmoother.reset,
                             forget_frames=options.new_faces.forget_frames,
                             lost=LandmarkSmoother.reset)
        self.warp_path = "none"
        self._last = -1

    def __call__(self, image: np.ndarray, frame: FrameRef) -> list[FaceFit]:
        """The fits of ``image`` (BGR or grey uint8): one per face tracked, by id, or one
        entry without a face (``face_id`` -1: a failed fit's landmarks, or none).

        A frame index that does not follow the last one starts afresh (the source went
        back).

        Raises
        ------
        ValueError
            For something that is not an image array.
        """
        if frame.index <= self._last:
            self.reset()
        self._last = frame.index
        self.warp.take_path()
        tracked, failed = self.tracker.track(image)
        self.warp_path = self.warp.take_path()
        found = [(face.face_id, face.fit) for face in tracked] or [(NOBODY, failed)]
        fits = [self._smoothed(face_id, fit, frame) for face_id, fit in found]
        if failed is None and not tracked:
            dark = darkness(image)
            if dark:
                fits = [replace(fits[0], reason=f"{NO_FACE}: {dark}")]
        return fits

    def _smoothed(self, face_id: int, fit: object, frame: FrameRef) -> FaceFit:
        smoother = self.faces.of(face_id, frame.index)
        if self.options.landmark_smoothing:
            fit = smoother.smoothed(fit, frame.t)  # a failed fit (or none) restarts it
        return FaceFit.of(face_id, fit, self.scheme)  # type: ignore[arg-type]

    def warm_up(self) -> None:
        """Fit once on a blank frame, and warp it once where the fitter warps, so that the
        first real frame pays no set-up costs (the GL context, shaders and textures,
        first-call allocations); the warm-up's warps are not counted."""
        fitter, warp = self.fitter, self.warp
        blank = np.full((480, 640, 3), 128, np.uint8)
        box = np.array([220.0, 140.0, 200.0, 200.0])
        try:
            if fitter.warps:
                warp.start()
                start = fitter.mapping.place(box, "detector")
                warp.warp(fitter.aam.prepare_image(blank, start), start)
            fitter.fit_box(blank, box)
        except (ValueError, FloatingPointError, np.linalg.LinAlgError) as exc:
            logging.getLogger("aamtrack.fit").debug("warm-up fit failed: %s", exc)
        warp.counts = dict.fromkeys(warp.counts, 0)
        warp.seconds = dict.fromkeys(warp.seconds, 0.0)
        warp.take_path()

    def search_with(self, detector: FaceDetector) -> None:
        """Search for faces with ``detector`` from now on."""
        self.tracker.detector = detector
        for face in self.tracker.faces:
            face.tracker.detector = detector

    def reset(self) -> None:
        """Forget the faces: the next frame starts from a search."""
        self.tracker.reset()
        self.faces.clear()
        self._last = -1

    def close(self) -> None:
        """End the GL warp worker if one was started (a later warp starts it again)."""
        self.warp.close()
