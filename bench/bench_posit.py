"""Bench: POSIT head pose against OpenCV's SQPNP, and which rigid subset to use.

1. Accuracy on exact projections of ``openface_mean68`` under random known
   poses (roll, pitch, yaw uniform in +-40 deg; distance 40-120 cm; the head
   seen within the central half of a 640x480 image, 60 deg horizontal field
   of view) with Gaussian pixel noise of 0, 1, 2 and 3 px: mean absolute error
   per angle and of the distance, for plain POSIT (thesis Algorithm 9), POSIT
   followed by Gauss-Newton refinement (the default of ``Posit``) and
   ``cv2.solvePnP(..., SOLVEPNP_SQPNP)``.
2. The targets, at 1 px noise and 60 cm: MAE <= 1.0 deg per angle and
   <= 0.5 cm distance, within 1.2x of SQPNP; under 0.5 ms per call for 68
   points.
3. Rigid subsets: faces drawn from the Surrey Face Model (identity PCA and
   the six expression blendshapes, via ``eos-py``), whose iBUG-68 and IMM-73
   points are projected under random poses with 1 px noise, and estimated with
   the *mean* model (``openface68``, ``imm73``) restricted to each subset: the
   error a generic model makes on varied faces. Jaw points slide along the
   face outline as the head turns (see :class:`SurreyFaces`).

Run: ``python bench/bench_posit.py [--trials 1000] [--seed 0]``
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from aamcore.config import data_root
from aamcore.pose.align import similarity_transform
from aamcore.pose.head_model import RECOMMENDED_SUBSET, SUBSETS, HeadModel, imm73, openface68
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.mesh import Mesh, SurfacePoints, lift_frontal, surrey_ibug_vertices
from aamcore.pose.posit import Posit
from aamcore.pose.rotation import rotation_from_rpy, rpy_from_rotation

CAMERA = CameraIntrinsics.from_fov(640, 480, 60.0)
NOISE_LEVELS = (0.0, 1.0, 2.0, 3.0)
TARGET_DEG, TARGET_CM, TARGET_RATIO, TARGET_MS = 1.0, 0.5, 1.2, 0.5

Estimator = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


@dataclass(frozen=True)
class Truth:
    """A known pose: rotation (3, 3), translation (3,) in mm."""

    R: np.ndarray
    T: np.ndarray


def random_pose(rng: np.random.Generator, distance_mm: float | None = None) -> Truth:
    """Roll, pitch, yaw uniform in +-40 deg; |T| uniform 400-1200 mm unless given."""
    R = rotation_from_rpy(*rng.uniform(-40.0, 40.0, 3))
    dist = rng.uniform(400.0, 1200.0) if distance_mm is None else distance_mm
    u = rng.uniform(0.25, 0.75) * CAMERA.width
    v = rng.uniform(0.25, 0.75) * CAMERA.height
    ray = np.linalg.solve(CAMERA.K, [u, v, 1.0])
    return Truth(R, ray / np.linalg.norm(ray) * dist)


def errors(R: np.ndarray, T: np.ndarray, truth: Truth) -> np.ndarray:
    """|roll|, |pitch|, |yaw| errors (deg) and |distance| error (cm), shape (4,)."""
    d_ang = np.array(rpy_from_rotation(R)) - np.array(rpy_from_rotation(truth.R))
    d_ang = (d_ang + 180.0) % 360.0 - 180.0
    d_cm = (np.linalg.norm(T) - np.linalg.norm(truth.T)) / 10.0
    return np.abs(np.append(d_ang, d_cm))


def estimators(model: np.ndarray) -> dict[str, Estimator]:
    """Plain POSIT, POSIT + Gauss-Newton (the default) and SQPNP for one model."""
    plain = Posit(model, refine_iterations=0)
    refined = Posit(model)

    def posit_fn(p: Posit) -> Estimator:
        def run(uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            est = p.estimate(uv, CAMERA)
            return est.R, est.T

        return run

    def sqpnp(uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        _, rvec, tvec = cv2.solvePnP(model, uv, CAMERA.K, None, flags=cv2.SOLVEPNP_SQPNP)
        return cv2.Rodrigues(rvec)[0], tvec.ravel()

    return {"POSIT": posit_fn(plain), "POSIT+GN": posit_fn(refined), "SQPNP": sqpnp}


def accuracy(
    model: np.ndarray,
    noise_px: float,
    trials: int,
    rng: np.random.Generator,
    distance_mm: float | None = None,
) -> dict[str, np.ndarray]:
    """Mean absolute errors (roll, pitch, yaw deg, distance cm) per estimator."""
    ests = estimators(model)
    errs: dict[str, list[np.ndarray]] = {name: [] for name in ests}
    for _ in range(trials):
        truth = random_pose(rng, distance_mm)
        uv = CAMERA.project(model, truth.R, truth.T) + rng.normal(0.0, noise_px, (len(model), 2))
        for name, fn in ests.items():
            errs[name].append(errors(*fn(uv), truth))
    return {name: np.mean(e, axis=0) for name, e in errs.items()}


def print_table(title: str, table: dict[str, np.ndarray]) -> None:
    print(f"\n{title}")
    print(f"  {'estimator':<20}{'roll':>8}{'pitch':>8}{'yaw':>8}{'dist cm':>9}")
    for name, e in table.items():
        print(f"  {name:<20}{e[0]:8.3f}{e[1]:8.3f}{e[2]:8.3f}{e[3]:9.3f}")
    ref = table.get("SQPNP")
    if ref is not None:
        for name, e in table.items():
            if name != "SQPNP":
                cells = [f"{a / b:.2f}" if b > 1e-6 else "n/a" for a, b in zip(e, ref, strict=True)]
                print(f"  {name + '/SQPNP':<20}" + "".join(f"{c:>8}" for c in cells[:3])
                      + f"{cells[3]:>9}")


def time_per_call_ms(
    fn: Estimator, frames: list[np.ndarray], repeats: int = 5
) -> tuple[float, float]:
    """Best-of-``repeats`` mean time per call over the frames: (wall ms, CPU ms).

    The CPU time of this process is what a call costs; the wall time also
    counts waiting for the CPU when other processes share the machine.
    """
    wall = cpu = np.inf
    for _ in range(repeats):
        w0, c0 = time.perf_counter(), time.process_time()
        for uv in frames:
            fn(uv)
        wall = min(wall, (time.perf_counter() - w0) / len(frames))
        cpu = min(cpu, (time.process_time() - c0) / len(frames))
    return wall * 1e3, cpu * 1e3


# --- rigid subsets on Surrey faces ------------------------------------------------


@dataclass(frozen=True)
class Markup:
    """Where a landmark scheme's points sit on the Surrey 3448 mesh.

    Attributes
    ----------
    model : HeadModel
        The full mean model of the scheme used to estimate the pose.
    surface : SurfacePoints
        Every landmark as a point of the mesh surface.
    outline : (K,) int array
        Landmarks on the face outline (the jaw), which slide with the view.
    """

    model: HeadModel
    surface: SurfacePoints
    outline: np.ndarray


class SurreyFaces:
    """Landmarks of faces drawn from the Surrey Face Model, in the OpenFace frame.

    The 3448-vertex model gives identity (63 PCA components) and six expression
    blendshapes; its mean is aligned to ``openface_mean68`` by a similarity on
    the iBUG points that ``ibug_to_sfm.txt`` maps. Landmarks are fixed surface
    points of the mesh:

    - iBUG-68: the mapped vertices; the jaw points and the two inner mouth
      corners take the vertex of the mean face nearest (3D) to the OpenFace point;
    - IMM-73: each point of the ``imm73`` model lifted frontally onto the mean
      face (the jaw points: nearest vertex).

    Jaw points are outline points: on a real face they slide over the skin as
    the head turns, so under each pose each moves to the vertex of the face's
    outline seen from the camera (occluding contour or mesh border, below the
    eyes, off the nose and lips) whose image is nearest the image of its fixed
    vertex, as eos matches contour landmarks.
    """

    def __init__(self) -> None:
        import eos  # eos-py: reads the Surrey model's cereal files

        folder = data_root() / "models3d" / "surrey_sfm"
        model = eos.morphablemodel.load_model(str(folder / "sfm_shape_3448.bin"))
        self.shape_model = model.get_shape_model()
        blend = eos.morphablemodel.load_blendshapes(str(folder / "expression_blendshapes_3448.bin"))
        self.blendshapes = np.array([np.asarray(b.deformation) for b in blend])  # (6, 3V)
        self.n_components = self.shape_model.get_num_principal_components()
        triangles = np.asarray(self.shape_model.get_triangle_list(), dtype=np.int64)
        mean = self._to_opencv(np.asarray(self.shape_model.get_mean()))
        ref = openface68().points
        vertex_of = surrey_ibug_vertices(len(mean))
        mapped = sorted(vertex_of)
        self.to_ref = similarity_transform(mean[[vertex_of[i] for i in mapped]], ref[mapped])
        self.mesh = Mesh(self.to_ref.apply(mean), triangles, None, "surrey3448")
        edges = np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
        uniq, counts = np.unique(edges, axis=0, return_counts=True)
        self.border = np.zeros(len(mean), dtype=bool)
        self.border[uniq[counts == 1].ravel()] = True
        # Outline candidates: below the eyes, and not the nose or lips, whose edges are
        # occluding contours too once the head turns.
        v = self.mesh.vertices
        centre = (np.abs(v[:, 0]) < 35.0) & (v[:, 1] < ref[57, 1] + 5.0)
        self.lower = (v[:, 1] > ref[36:48, 1].mean()) & ~centre
        for i in range(68):
            if i not in vertex_of:
                vertex_of[i] = self._nearest_vertex(ref[i])
        self.markups = {
            "ibug68": Markup(openface68(), self._at_vertices([vertex_of[i] for i in range(68)]),
                             np.arange(17)),
            "imm73": self._imm_markup(),
        }

    @staticmethod
    def _to_opencv(flat: np.ndarray) -> np.ndarray:
        return flat.reshape(-1, 3) * np.array([1.0, -1.0, -1.0])

    def _nearest_vertex(self, point: np.ndarray) -> int:
        return int(np.argmin(np.sum((self.mesh.vertices - point) ** 2, axis=1)))

    def _at_vertices(self, vertices: list[int]) -> SurfacePoints:
        rows = [np.argwhere(self.mesh.triangles == v)[0] for v in vertices]
        return SurfacePoints(np.array([r[0] for r in rows]), np.eye(3)[[r[1] for r in rows]],
                             np.ones(len(vertices), dtype=bool))

    def _imm_markup(self) -> Markup:
        model = imm73()
        jaw = np.arange(62, 73)
        lifted = lift_frontal(self.mesh, model.points[:, :2])
        at_jaw = self._at_vertices([self._nearest_vertex(p) for p in model.points[jaw]])
        tri, bary = lifted.triangle.copy(), lifted.bary.copy()
        tri[jaw], bary[jaw] = at_jaw.triangle, at_jaw.bary
        return Markup(model, SurfacePoints(tri, bary, np.ones(73, dtype=bool)), jaw)

    def draw(self, rng: np.random.Generator, identity: bool, expression: bool) -> np.ndarray:
        """All vertices (mm, OpenFace frame) of a random face, shape (3448, 3)."""
        coeffs = rng.standard_normal(self.n_components) if identity else np.zeros(
            self.n_components)
        flat = np.asarray(self.shape_model.draw_sample(coeffs))
        if expression:
            weights = np.zeros(len(self.blendshapes))
            weights[rng.integers(len(weights))] = rng.uniform(0.0, 1.0)
            flat = flat + weights @ self.blendshapes
        return self.to_ref.apply(self._to_opencv(flat))

    def outline(self, face: np.ndarray, truth: Truth) -> np.ndarray:
        """Vertices of ``face`` on its outline seen under ``truth``, below the eyes."""
        eye = -truth.R.T @ truth.T  # camera centre in the face frame
        tris = self.mesh.triangles
        tri = face[tris]
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        front = np.einsum("fd,fd->f", normal, tri.mean(axis=1) - eye) < 0
        n_front = np.bincount(tris.ravel(), np.repeat(front, 3), len(face))
        n_all = np.bincount(tris.ravel(), minlength=len(face))
        contour = (n_front > 0) & (n_front < n_all)
        return np.flatnonzero((contour | (self.border & (n_front > 0))) & self.lower)

    def landmarks(self, face: np.ndarray, truth: Truth, scheme: str) -> np.ndarray:
        """The scheme's landmarks on ``face`` seen under ``truth``, shape (N, 3)."""
        markup = self.markups[scheme]
        points = markup.surface.positions(self.mesh, face)
        candidates = self.outline(face, truth)
        seen = CAMERA.project(face[candidates], truth.R, truth.T)
        anchors = CAMERA.project(points[markup.outline], truth.R, truth.T)
        d2 = np.sum((seen[None] - anchors[:, None]) ** 2, axis=2)
        points[markup.outline] = face[candidates[np.argmin(d2, axis=1)]]
        return points


def subset_errors(
    faces: SurreyFaces,
    scheme: str,
    models: dict[str, HeadModel],
    identity: bool,
    expression: bool,
    trials: int,
    rng: np.random.Generator,
) -> dict[str, np.ndarray]:
    """Per-trial errors (roll, pitch, yaw, distance) per subset model: (trials, 4) each."""
    posits = {name: m.posit() for name, m in models.items()}
    errs: dict[str, list[np.ndarray]] = {name: [] for name in models}
    for _ in range(trials):
        truth = random_pose(rng)
        face = faces.landmarks(faces.draw(rng, identity, expression), truth, scheme)
        uv = CAMERA.project(face, truth.R, truth.T) + rng.normal(0.0, 1.0, (len(face), 2))
        for name, p in posits.items():
            est = p.estimate(models[name].select(uv), CAMERA)
            errs[name].append(errors(est.R, est.T, truth))
    return {name: np.array(e) for name, e in errs.items()}


def rigid_subsets(
    faces: SurreyFaces, scheme: str, trials: int, rng: np.random.Generator
) -> tuple[str, str]:
    """Print the subset comparison for one scheme.

    Returns the best subset under identity + expression variation (lowest
    mean angle error) and a verdict on the recommended subset: "best", "tied"
    (paired difference within two standard errors), "worse" or "none" (no
    recommendation).
    """
    full = faces.markups[scheme].model
    models = {name: full.subset(name) for name in SUBSETS[scheme]}
    best, verdict = "", ""
    for label, identity, expression in (
        ("identity only", True, False),
        ("expression only", False, True),
        ("identity + expression", True, True),
    ):
        per_trial = subset_errors(faces, scheme, models, identity, expression, trials, rng)
        table = {name: e.mean(axis=0) for name, e in per_trial.items()}
        angle = {name: e[:, :3].mean(axis=1) for name, e in per_trial.items()}
        print(f"\nrigid subsets, {scheme} on Surrey faces ({label}), mean {full.name} model, "
              f"1 px noise, {trials} poses, 40-120 cm; 'mean' = mean of the angle MAEs, SE its "
              "standard error")
        print(f"  {'subset':<31}{'points':>7}{'roll':>7}{'pitch':>7}{'yaw':>7}{'mean':>7}"
              f"{'SE':>6}{'dist cm':>9}")
        order = sorted(table, key=lambda k: float(np.mean(table[k][:3])))
        for name in order:
            e = table[name]
            se = angle[name].std(ddof=1) / np.sqrt(trials)
            print(f"  {name:<31}{len(models[name].indices):7d}{e[0]:7.2f}{e[1]:7.2f}{e[2]:7.2f}"
                  f"{np.mean(e[:3]):7.2f}{se:6.2f}{e[3]:9.2f}")
        best = order[0]
        rec = RECOMMENDED_SUBSET.get(scheme)
        if rec is None:
            verdict = "none"
            continue
        diff = angle[rec] - angle[best]
        se_diff = diff.std(ddof=1) / np.sqrt(trials) if rec != best else 0.0
        verdict = "best" if rec == best else "tied" if diff.mean() <= 2 * se_diff else "worse"
        print(f"  recommended {rec!r} - best {best!r}: {diff.mean():+.3f} deg "
              f"(paired SE {se_diff:.3f}) -> {verdict}")
    return best, verdict


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=1000, help="poses per condition")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--skip-subsets", action="store_true")
    args = parser.parse_args(argv)
    cv2.setNumThreads(1)
    rng = np.random.default_rng(args.seed)
    model = openface68().points
    print(f"camera: {CAMERA.width}x{CAMERA.height}, f = {CAMERA.focal[0]:.1f} px "
          f"({CAMERA.horizontal_fov_deg:.0f} deg); model: openface_mean68 ({len(model)} points)")
    print("errors: mean absolute, degrees (roll, pitch, yaw) and cm (distance)")

    for noise in NOISE_LEVELS:
        table = accuracy(model, noise, args.trials, rng)
        print_table(f"noise {noise:g} px, distance 40-120 cm, {args.trials} poses", table)

    target = accuracy(model, 1.0, args.trials, rng, distance_mm=600.0)
    print_table(f"TARGET: noise 1 px, distance 60 cm, {args.trials} poses", target)

    frames = []
    for _ in range(500):
        truth = random_pose(rng)
        frames.append(CAMERA.project(model, truth.R, truth.T) + rng.normal(0, 1.0, (68, 2)))
    times = {name: time_per_call_ms(fn, frames) for name, fn in estimators(model).items()}
    print("\ntime per call, 68 points (best of 5 runs of 500 frames)")
    print(f"  {'estimator':<20}{'wall ms':>9}{'CPU ms':>9}")
    for name, (wall, cpu) in times.items():
        print(f"  {name:<20}{wall:9.3f}{cpu:9.3f}")
    timing = {name: cpu for name, (_, cpu) in times.items()}

    subsets: dict[str, tuple[str, str]] = {}
    if not args.skip_subsets:
        try:
            faces = SurreyFaces()
        except ImportError:
            print("\nrigid subsets: skipped (pip install eos-py to read the Surrey model)")
        else:
            for scheme in ("ibug68", "imm73"):
                subsets[scheme] = rigid_subsets(faces, scheme, args.trials, rng)

    print()
    ok = True
    for name in ("POSIT+GN", "POSIT"):
        e, ratio = target[name], target[name] / np.maximum(target["SQPNP"], 1e-12)
        acc_ok = bool(np.all(e[:3] <= TARGET_DEG) and e[3] <= TARGET_CM)
        ratio_ok = bool(np.all(ratio <= TARGET_RATIO))
        fast = timing[name] < TARGET_MS
        default = name == "POSIT+GN"
        ok &= (acc_ok and ratio_ok and fast) or not default
        tag = "" if default else " (plain POSIT, for information)"
        print(f"{'PASS' if acc_ok else 'FAIL'} {name} accuracy at 1 px, 60 cm: roll {e[0]:.3f}, "
              f"pitch {e[1]:.3f}, yaw {e[2]:.3f} deg (<= {TARGET_DEG}), distance {e[3]:.3f} cm "
              f"(<= {TARGET_CM}){tag}")
        print(f"{'PASS' if ratio_ok else 'FAIL'} {name} vs SQPNP: worst ratio {ratio.max():.2f} "
              f"(<= {TARGET_RATIO}){tag}")
        print(f"{'PASS' if fast else 'FAIL'} {name} time: {timing[name]:.3f} ms CPU per call for "
              f"68 points (< {TARGET_MS}){tag}")
    for scheme, (best, verdict) in subsets.items():
        agree = verdict in ("best", "tied")
        print(f"{'PASS' if agree else 'FAIL'} rigid subset {scheme}: recommended "
              f"{RECOMMENDED_SUBSET.get(scheme)!r} is {verdict} (best measured {best!r}, "
              "identity + expression)")
        ok &= agree
    print("PASS" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
