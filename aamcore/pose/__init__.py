"""Head pose from landmarks: POSIT, camera intrinsics, 3D head models, plane pose.

Thesis chapters 13 and 14 and appendix A.
"""

from aamcore.pose.errors import IntrinsicsError, PoseError
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.posit import PoseEstimate, Posit
from aamcore.pose.rotation import RPY, rotation_from_rpy, rpy_from_rotation

__all__ = [
    "RPY",
    "CameraIntrinsics",
    "IntrinsicsError",
    "Posit",
    "PoseError",
    "PoseEstimate",
    "rotation_from_rpy",
    "rpy_from_rotation",
]
