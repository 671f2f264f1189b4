"""Pose accuracy over a sequence with known poses (thesis section 14.2, table 14.1).

- :func:`evaluate_pose_sequence`: POSIT on the landmarks of each frame (from
  an AAM fit or exact), compared with the true pose: per-frame angles and
  distance, and per-parameter error statistics (mean, standard deviation as
  in table 14.1, mean absolute, largest).
- :func:`posit_vs_sqpnp`: the same on exact landmarks with added Gaussian
  pixel noise, for POSIT and OpenCV's SQPNP side by side.
- :func:`plot_pose_sequence`: estimate against truth per frame, as figure 14.4.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from aamcore.pose.errors import PoseError
from aamcore.pose.head_model import HeadModel
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.posit import Posit
from aamcore.pose.rotation import rpy_from_rotation

PARAMETERS = ("roll", "pitch", "yaw", "distance_cm")

Truth = tuple[np.ndarray, np.ndarray] | Mapping[str, Any]


def _truth_pose(truth: Truth) -> tuple[np.ndarray, np.ndarray]:
    if isinstance(truth, Mapping):
        R, T = truth["R"], truth["T"]
    elif hasattr(truth, "R") and hasattr(truth, "T"):
        R, T = truth.R, truth.T  # type: ignore[union-attr]
    else:
        R, T = truth
    return np.asarray(R, dtype=np.float64), np.asarray(T, dtype=np.float64).ravel()


def pose_parameters(R: np.ndarray, T: np.ndarray) -> dict[str, float]:
    """Roll, pitch, yaw (deg) and distance (cm, ``|T|`` of a mm translation)."""
    rpy = rpy_from_rotation(R)
    return {"roll": rpy.roll, "pitch": rpy.pitch, "yaw": rpy.yaw,
            "distance_cm": float(np.linalg.norm(T)) / 10.0}


def error_statistics(errors: np.ndarray) -> dict[str, dict[str, float]]:
    """Per-parameter statistics of signed errors of shape (F, 4) (roll, pitch, yaw, cm)."""
    stats: dict[str, dict[str, float]] = {}
    for k, name in enumerate(PARAMETERS):
        e = errors[:, k] if len(errors) else np.zeros(0)
        stats[name] = {
            "mean": float(e.mean()) if e.size else float("nan"),
            "std": float(e.std(ddof=1)) if e.size > 1 else float("nan"),
            "mae": float(np.abs(e).mean()) if e.size else float("nan"),
            "max_abs": float(np.abs(e).max()) if e.size else float("nan"),
        }
    return stats


def signed_errors(est: dict[str, float], truth: dict[str, float]) -> list[float]:
    """Estimate minus truth per parameter (roll, pitch, yaw wrapped to [-180, 180), cm)."""
    out = []
    for name in PARAMETERS:
        d = est[name] - truth[name]
        out.append((d + 180.0) % 360.0 - 180.0 if name != "distance_cm" else d)
    return out


def _frame_record(
    index: int,
    landmarks: np.ndarray | None,
    truth: Truth,
    intrinsics: CameraIntrinsics,
    model: HeadModel,
    posit: Posit,
) -> tuple[dict[str, Any], str]:
    """One frame of :func:`evaluate_pose_sequence`: its ``per_frame`` record and outcome.

    The outcome is ``"estimated"`` (a reliable estimate), ``"unreliable"``,
    ``"missing"`` (no landmarks) or ``"failed"`` (PoseError).
    """
    true_params = pose_parameters(*_truth_pose(truth))
    record: dict[str, Any] = {"frame": index, "truth": true_params, "estimate": None,
                              "reliable": False, "reason": ""}
    if landmarks is None:
        record["reason"] = "no landmarks"
        return record, "missing"
    try:
        est = posit.estimate(model.select(np.asarray(landmarks)), intrinsics)
    except PoseError as exc:
        record["reason"] = str(exc)
        return record, "failed"
    record.update(estimate=pose_parameters(est.R, est.T), reliable=est.reliable,
                  reason=est.reason, rms_px=est.rms_px)
    return record, "estimated" if est.reliable else "unreliable"


def evaluate_pose_sequence(
    landmarks_per_frame: Sequence[np.ndarray | None],
    truth_per_frame: Sequence[Truth],
    intrinsics: CameraIntrinsics,
    model: HeadModel,
    posit: Posit | None = None,
) -> dict[str, Any]:
    """Estimate each frame's pose with POSIT and compare it with the truth.

    Parameters
    ----------
    landmarks_per_frame : sequence of (n_landmarks, 2) arrays or None
        All landmarks of the model's scheme per frame, pixels; None where the
        tracker had no fit.
    truth_per_frame : sequence
        True poses: ``(R, T)`` pairs, objects with ``R`` and ``T``, or dicts
        with ``"R"`` and ``"T"`` (T in mm, in the model's frame).
    intrinsics : CameraIntrinsics
    model : HeadModel
        The 3D model (and subset) to estimate with.
    posit : Posit, optional
        A ready estimator for ``model`` (default ``model.posit()``).

    Returns
    -------
    dict
        JSON-ready: ``frames``, ``estimated`` (reliable estimates), ``unreliable``,
        ``missing``, ``failed`` (PoseError), ``per_frame`` (truth, estimate or
        None, reliable, reason) and ``errors`` (statistics of reliable frames
        per parameter: mean, std, mae, max_abs; degrees and cm).

    Raises
    ------
    ValueError
        If the two sequences differ in length.
    """
    if len(landmarks_per_frame) != len(truth_per_frame):
        raise ValueError(f"{len(landmarks_per_frame)} landmark frames but "
                         f"{len(truth_per_frame)} true poses")
    posit = posit or model.posit()
    per_frame: list[dict[str, Any]] = []
    errors: list[list[float]] = []
    counts = {"unreliable": 0, "missing": 0, "failed": 0}
    for i, (landmarks, truth) in enumerate(zip(landmarks_per_frame, truth_per_frame,
                                               strict=True)):
        record, outcome = _frame_record(i, landmarks, truth, intrinsics, model, posit)
        per_frame.append(record)
        if outcome == "estimated":
            errors.append(signed_errors(record["estimate"], record["truth"]))
        else:
            counts[outcome] += 1
    return {"frames": len(per_frame), "estimated": len(errors), **counts,
            "model": model.name, "errors": error_statistics(np.array(errors).reshape(-1, 4)),
            "per_frame": per_frame}


def _sqpnp(model: np.ndarray, uv: np.ndarray, camera: CameraIntrinsics
           ) -> tuple[np.ndarray, np.ndarray]:
    dist = camera.dist if camera.has_distortion else None
    _, rvec, tvec = cv2.solvePnP(model, uv, camera.K, dist, flags=cv2.SOLVEPNP_SQPNP)
    return cv2.Rodrigues(rvec)[0], tvec.ravel()


def posit_vs_sqpnp(
    landmarks_per_frame: Sequence[np.ndarray],
    truth_per_frame: Sequence[Truth],
    intrinsics: CameraIntrinsics,
    model: HeadModel,
    noise_px: Sequence[float] = (0.0, 1.0, 2.0, 3.0),
    seed: int = 0,
) -> dict[str, Any]:
    """POSIT (plain and refined) and SQPNP on landmarks with added Gaussian noise.

    Parameters
    ----------
    landmarks_per_frame : sequence of (n_landmarks, 2) arrays
        Exact landmarks per frame.
    truth_per_frame : sequence
        True poses, as in :func:`evaluate_pose_sequence`.
    intrinsics : CameraIntrinsics
    model : HeadModel
    noise_px : sequence of float
        Standard deviations of the noise added to both coordinates, pixels.
    seed : int

    Returns
    -------
    dict
        ``{"model": name, "frames": F, "noise": [{"noise_px": s, "POSIT": stats,
        "POSIT+GN": stats, "SQPNP": stats}, ...]}`` with :func:`error_statistics`.
    """
    rng = np.random.default_rng(seed)
    truths = [pose_parameters(*_truth_pose(t)) for t in truth_per_frame]
    posits = {"POSIT": Posit(model.points, refine_iterations=0), "POSIT+GN": Posit(model.points)}
    results = []
    for sigma in noise_px:
        errs: dict[str, list[list[float]]] = {name: [] for name in (*posits, "SQPNP")}
        for landmarks, truth in zip(landmarks_per_frame, truths, strict=True):
            uv = model.select(np.asarray(landmarks))
            uv = uv + rng.normal(0.0, sigma, uv.shape)
            for name, p in posits.items():
                est = p.estimate(uv, intrinsics)
                errs[name].append(signed_errors(pose_parameters(est.R, est.T), truth))
            errs["SQPNP"].append(signed_errors(
                pose_parameters(*_sqpnp(model.points, uv, intrinsics)), truth))
        results.append({"noise_px": float(sigma),
                        **{k: error_statistics(np.array(v)) for k, v in errs.items()}})
    return {"model": model.name, "frames": len(truths), "noise": results}


def plot_pose_sequence(result: dict[str, Any], path: str | Path, title: str = "") -> Path:
    """Plot estimate against truth per frame (pitch, yaw, roll, distance), as figure 14.4.

    Parameters
    ----------
    result : dict
        Output of :func:`evaluate_pose_sequence`.
    path : path
        PNG file to write.
    title : str
    """
    from aamcore.evaluation.plots import new_figure

    frames = [r["frame"] for r in result["per_frame"]]
    fig = new_figure(figsize=(8, 9))
    axes = fig.subplots(4, 1, sharex=True)
    for ax, (name, unit) in zip(axes, [("pitch", "deg"), ("yaw", "deg"), ("roll", "deg"),
                                       ("distance_cm", "cm")], strict=True):
        truth = [r["truth"][name] for r in result["per_frame"]]
        est = [r["estimate"][name] if r["estimate"] and r["reliable"] else np.nan
               for r in result["per_frame"]]
        ax.plot(frames, truth, "k-", lw=1.5, label="truth")
        ax.plot(frames, est, "r.", ms=4, label="POSIT")
        stats = result["errors"][name]
        ax.set_ylabel(f"{name.replace('_cm', '')} ({unit})")
        ax.set_title(f"{name.replace('_cm', '')}: error mean {stats['mean']:+.2f}, "
                     f"std {stats['std']:.2f} {unit}", fontsize=9)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("frame")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    return path


def sequence_inputs(folder: Path) -> tuple[list[np.ndarray], list[dict[str, Any]],
                                           CameraIntrinsics, HeadModel]:
    """A folder written by ``aamtrack synth``: its exact landmarks (F, 68, 2) per frame, true
    poses (``{"R", "T"}``), camera and the head model it was rendered with."""
    from aamcore.synth.sequence import load_sequence

    summary, records = load_sequence(folder)
    intr = summary["intrinsics"]
    camera = CameraIntrinsics(np.array(intr["camera_matrix"]),
                              np.array(intr["distortion_coefficients"]), intr["image_width"],
                              intr["image_height"], str(folder))
    exact = HeadModel("synth_sequence68", "ibug68", 68, np.arange(68),
                      np.array(summary["model_points_mm"]), str(folder))
    return ([np.array(r["landmarks"]) for r in records],
            [{"R": r["R"], "T": r["T"]} for r in records], camera, exact)


def tracked_sequence_errors(frames: Any, truths: Sequence[Any], camera: CameraIntrinsics,
                            model: HeadModel, tracker: Any) -> dict[str, Any]:
    """Pose errors (as :func:`evaluate_pose_sequence`, without the per-frame rows) of the
    landmarks ``tracker`` (:class:`aamcore.fitting.tracker.Tracker`) finds in ``frames``,
    and its failed fits."""
    from aamcore.evaluation.tracking import track_frames

    landmarks, flagged = track_frames(frames, tracker)
    result = evaluate_pose_sequence(landmarks, truths, camera, model)
    return {k: v for k, v in result.items() if k != "per_frame"} | {"failed_fits": flagged}
