"""Head pose from a 3D face fitted to the landmarks (eos-py, Surrey Face Model).

:class:`EosPose` fits the Surrey Face Model 3448 (shape PCA and six
expression blendshapes) to the 68 iBUG landmarks of one fit with eos's
``fit_shape_and_pose``, which also matches the jaw landmarks to the model's
outline (contour correspondences). eos's camera is scaled orthographic, so
the fitted face's landmark vertices are moved into the frame of
:func:`aamcore.pose.head_model.openface68` (the similarity that maps the mean
Surrey face's iBUG vertices onto OpenFace's points) and the perspective pose is
then found from them, by SQPNP and Gauss-Newton on the inner landmarks. So the
pose is in the same frame as POSIT's, with a face shape fitted per frame
instead of the mean one.

Needs ``eos-py`` (an optional dependency: ``pip install eos-py``). Bench only
(``bench/bench_pose_yaw.py --eos``): about 50 ms per estimate.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import cv2
import numpy as np

from aamcore.config import data_root
from aamcore.pose.align import align_points
from aamcore.pose.errors import PoseError
from aamcore.pose.head_model import openface68
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.mesh import surrey_ibug_vertices
from aamcore.pose.posit import PoseEstimate
from aamcore.pose.refine import gauss_newton


@lru_cache(maxsize=1)
def _eos_assets() -> dict[str, Any]:
    try:
        import eos
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise PoseError("EosPose needs eos-py (pip install eos-py)") from exc
    folder = data_root() / "models3d" / "surrey_sfm"
    model = eos.morphablemodel.load_model(str(folder / "sfm_shape_3448.bin"))
    blend = eos.morphablemodel.load_blendshapes(str(folder / "expression_blendshapes_3448.bin"))
    morphable = eos.morphablemodel.MorphableModel(
        model.get_shape_model(), blend, color_model=eos.morphablemodel.PcaModel(),
        vertex_definitions=None, texture_coordinates=model.get_texture_coordinates())
    mapping_file = str(folder / "ibug_to_sfm.txt")
    mean = np.asarray(model.get_shape_model().get_mean()).reshape(-1, 3) * [1.0, -1.0, -1.0]
    vertex_of = surrey_ibug_vertices(len(mean))
    mapped = sorted(vertex_of)
    ref = openface68().points
    to_ref = align_points(mean[[vertex_of[i] for i in mapped]], ref[mapped])
    return {
        "eos": eos,
        "model": morphable,
        "mapper": eos.core.LandmarkMapper(mapping_file),
        "edges": eos.morphablemodel.load_edge_topology(str(folder / "sfm_3448_edge_topology.json")),
        "contour_landmarks": eos.fitting.ContourLandmarks.load(mapping_file),
        "model_contour": eos.fitting.ModelContour.load(str(folder / "sfm_model_contours.json")),
        "inner": np.array([i for i in mapped if i >= 17], dtype=np.int64),
        "vertices": np.array([vertex_of[i] for i in mapped if i >= 17], dtype=np.int64),
        "to_ref": to_ref,
    }


class EosPose:
    """Pose from a per-frame Surrey Face Model fit (eos-py), in POSIT's frame.

    Parameters
    ----------
    iterations : int
        eos's alternations of pose, contour, expression and shape fitting.
    shape_coefficients : int or None
        Identity components fitted (None: all 63).
    lambda_identity, lambda_expressions : float
        eos's regularisation of identity and expression.
    max_relative_rms : float
        Flag unreliable when the perspective fit's RMS residual exceeds this
        fraction of the face size.
    """

    def __init__(self, iterations: int = 5, shape_coefficients: int | None = None,
                 lambda_identity: float = 30.0, lambda_expressions: float = 30.0,
                 max_relative_rms: float = 0.1) -> None:
        self.assets = _eos_assets()
        self.iterations = int(iterations)
        self.shape_coefficients = shape_coefficients
        self.lambda_identity = float(lambda_identity)
        self.lambda_expressions = float(lambda_expressions)
        self.max_relative_rms = float(max_relative_rms)

    def fit_shape(self, landmarks: np.ndarray, camera: CameraIntrinsics) -> np.ndarray:
        """The fitted face's inner landmark vertices in the OpenFace frame, (M, 3) mm."""
        a = self.assets
        eos = a["eos"]
        marks = [eos.core.Landmark(str(i + 1), np.asarray(p, dtype=np.float32))
                 for i, p in enumerate(landmarks)]
        mesh, _, _, _ = eos.fitting.fit_shape_and_pose(
            a["model"], marks, a["mapper"], int(camera.width), int(camera.height), a["edges"],
            a["contour_landmarks"], a["model_contour"], self.iterations,
            self.shape_coefficients, self.lambda_identity, None, self.lambda_expressions)
        V = np.asarray(mesh.vertices)[a["vertices"]] * [1.0, -1.0, -1.0]
        return a["to_ref"].apply(V)

    def estimate(self, landmarks: np.ndarray, camera: CameraIntrinsics) -> PoseEstimate:
        """Fit the face and return its perspective pose (OpenFace frame).

        Parameters
        ----------
        landmarks : (68, 2) array
            Pixels.
        camera : CameraIntrinsics
            With the image size (eos needs it).

        Raises
        ------
        PoseError
            For a wrong shape, non-finite landmarks or an unknown image size.
        """
        pts = np.asarray(landmarks, dtype=np.float64)
        if pts.shape != (68, 2) or not np.all(np.isfinite(pts)):
            raise PoseError(f"need 68 finite landmarks, got shape {pts.shape}")
        if camera.width <= 0 or camera.height <= 0:
            raise PoseError("EosPose needs the image size in the intrinsics")
        X = self.fit_shape(pts, camera)
        inner = self.assets["inner"]
        xy = camera.normalize(pts[inner])
        _, rvec, tvec = cv2.solvePnP(X, xy, np.eye(3), None, flags=cv2.SOLVEPNP_SQPNP)
        R, T = cv2.Rodrigues(rvec)[0], tvec.ravel()
        fxy = np.array(camera.focal)
        R, T = gauss_newton(R, T, X, xy, None, fxy, 2)
        P = X @ R.T + T
        err = (P[:, :2] / P[:, 2:3] - xy) * fxy
        rms = float(np.sqrt(np.mean(np.sum(err**2, axis=1))))
        size = float(np.sqrt(np.mean(np.sum((pts[inner] - pts[inner].mean(0)) ** 2, axis=1))))
        reason = ""
        if T[2] <= 0:
            reason = "no valid pose: the head would be behind the camera"
        elif rms > self.max_relative_rms * size:
            reason = f"landmarks do not fit the face: residual {rms:.1f} px"
        return PoseEstimate(R, T, self.iterations, True, reason == "", reason or "ok", rms)
