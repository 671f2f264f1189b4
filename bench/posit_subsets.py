"""Rigid point subsets of the head model compared on the Surrey model's identities and
expressions (``bench_posit.py``'s subset table)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aamcore.config import data_root
from aamcore.pose.align import align_points
from aamcore.pose.head_model import RECOMMENDED_SUBSET, SUBSETS, HeadModel, imm73, openface68
from aamcore.pose.mesh import Mesh, SurfacePoints, lift_frontal, surrey_ibug_vertices
from bench.posit_poses import CAMERA, Truth, errors, random_pose


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
        self.to_ref = align_points(mean[[vertex_of[i] for i in mapped]], ref[mapped])
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
