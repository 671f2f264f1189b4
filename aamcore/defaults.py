"""The defaults of the library, the command line and the services, defined once.

Everything that has a default and is chosen in more than one place (the
fitting algorithm, the failure test, the assumed field of view, the model the
stack trains on first use) reads it from here.
"""

from __future__ import annotations

ALGORITHM = "local-binary"
"""The fitting algorithm: landmark-HOG and fern stages in a shape space, the most accurate
on in-the-wild faces and the fastest to track (``bench/bench_fit_lfpw.py``,
``bench/bench_fit_speed.py``)."""
FAILURE_TESTS = ("auto", "chi2", "eq7.2", "quality")
"""The failure tests a fitter can be given (:mod:`aamcore.fitting.failure`)."""
FAILURE_TEST = "auto"
"""How a failed fit is recognised: ``auto`` is the learned quality score for
``local-binary`` and ``chi2`` on the appearance for the AAM methods (see
:mod:`aamcore.fitting.failure`)."""
FOV_DEG = 60.0
"""Horizontal field of view assumed for a camera without a calibration, degrees."""
DETECTOR = {"scale_factor": 1.1, "min_neighbors": 2, "min_size": (60, 60), "max_side": 320}
"""Haar detector settings (:class:`aamcore.detection.haar.HaarFaceDetector`, the alt2
cascade): frames are searched at most 320 px on their longer side, faces of at least 60 px.
Tuned on the training split of LFPW, HELEN and AFW (``bench/bench_detector_tuning.py``):
93.4 % of the faces found (94.2 % held out) against 84.0 % for scale 1.2 with 3
neighbours, 10 ms per 640x360 frame against 19 ms without the downscaling."""
THESIS_OFFSETS: tuple[int, ...] = tuple(
    sorted({s * v for v in (0, 1, 3, 5, 10, 15, 20, 25, 30, 35, 40, 45, 50) for s in (-1, 1)})
)
"""Displacements in pixels of the thesis's Monte Carlo fitting runs (tables 7.1, 7.2)."""
FIT_STARTS = ("cog", "haar")
"""The Monte Carlo runs' starts: centre of gravity and Haar box (section 7.3)."""
SVM_GRID_NAMES = ("full", "coarse")
"""Named (C, gamma) grids of the SVM search (:data:`aamcore.expression.svm.SVM_GRIDS`)."""
MODEL_DATASET = "lfpw,helen,afw"
"""What the default fitting model is trained on: the training splits of the three sets
(:mod:`aamcore.io.splits`), with their mirror images."""
MODEL_UPDATE_IMAGES = 30
"""Images the default model's update matrices are learned from."""
MODEL_AAM_IMAGES = 600
"""Faces the default model's AAM and supervised-descent cascade are trained on (spread over
its training faces; the local-binary cascade learns from all of them): the whole model
trains in under 5 minutes on two cores."""
POSE_ESTIMATORS = ("contour", "posit", "contour+calib")
"""Head-pose estimators (:class:`aamcore.pose.estimator.HeadPoseEstimator`): ``contour``
matches the jaw landmarks to the outline seen (:class:`aamcore.pose.robust.ContourPose`),
``posit`` is the thesis's POSIT without the jaw, ``contour+calib`` adapts the head model
to the person (:class:`aamcore.pose.calibrate.OnlineCalibration`)."""
POSE_ESTIMATOR = "contour"
"""The head-pose estimator of the stack and the library: it holds to +-60 degrees of yaw
where POSIT's jaw points mislead it (``bench/bench_pose_yaw.py``)."""
MAX_FACES = 64
"""The most faces tracked in a frame (a frame's fits count at most so many, as
``proto.messages.MAX_FACES`` says on the wire)."""
EXPRESSION_HOLD = 3
"""Classified frames a new expression label leads before it is shown (100 ms at 30 fps),
in the library and the stack alike: a label that flickers for a frame or two is not shown."""
