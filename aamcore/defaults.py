"""The defaults of the library, the command line and the services, defined once.

Everything that has a default and is chosen in more than one place (the
fitting algorithm, the failure test, the assumed field of view, the model the
stack trains on first use) reads it from here.
"""

from __future__ import annotations

ALGORITHM = "supervised-descent"
"""The fitting algorithm: the learned cascade, the most accurate on in-the-wild faces."""
FAILURE_TEST = "chi2"
"""How a failed fit is recognised (see :class:`aamcore.fitting.failure.FailureTest`)."""
FOV_DEG = 60.0
"""Horizontal field of view assumed for a camera without a calibration, degrees."""
DETECTOR = {"scale_factor": 1.2, "min_neighbors": 3, "min_size": (60, 60), "max_side": 320}
"""Haar detector settings (:class:`aamcore.detection.haar.HaarFaceDetector`): frames are
searched at most 320 px on their longer side, faces of at least 60 px."""
THESIS_OFFSETS: tuple[int, ...] = tuple(
    sorted({s * v for v in (0, 1, 3, 5, 10, 15, 20, 25, 30, 35, 40, 45, 50) for s in (-1, 1)})
)
"""Displacements in pixels of the thesis's Monte Carlo fitting runs (tables 7.1, 7.2)."""
FIT_STARTS = ("cog", "haar")
"""The Monte Carlo runs' starts: centre of gravity and Haar box (section 7.3)."""
SVM_GRID_NAMES = ("full", "coarse")
"""Named (C, gamma) grids of the SVM search (:data:`aamcore.expression.svm.SVM_GRIDS`)."""
MODEL_DATASET = "lfpw"
"""What the default fitting model is trained on."""
MODEL_UPDATE_IMAGES = 30
"""Images the default model's update matrices are learned from."""
POSE_ESTIMATORS = ("contour", "posit", "contour+calib")
"""Head-pose estimators (:class:`aamcore.pose.estimator.HeadPoseEstimator`): ``contour``
matches the jaw landmarks to the outline seen (:class:`aamcore.pose.robust.ContourPose`),
``posit`` is the thesis's POSIT without the jaw, ``contour+calib`` adapts the head model
to the person (:class:`aamcore.pose.calibrate.OnlineCalibration`)."""
POSE_ESTIMATOR = "contour"
"""The head-pose estimator of the stack and the library: it holds to +-60 degrees of yaw
where POSIT's jaw points mislead it (bench/bench_pose_yaw.py, PORT_REPORT.md)."""
