"""Rigid 3D head models for POSIT: one 3D point per landmark of a scheme.

All models are in millimetres with OpenCV axes (+x right, +y down, +z away
from the camera the face looks at). Subsets keep their full model's origin,
so the translation POSIT returns means the same for every subset; the IMM
model is built in the OpenFace model's frame (origin at the centroid of its 68
points), and a CSV model is moved to the centroid of its points.

- :func:`openface68`: the OpenFace mean iBUG-68 shape (``models3d/openface_mean68``).
- :func:`load_csv_model`: any scheme from a CSV file.
- :func:`imm73`: the IMM Frontal 73-point markup, built from the IMM
  annotations and the Surrey reference mesh (see the function's notes).

``rigid_subset`` leaves out points that move with expression; which subset
works best is measured by ``bench/bench_posit.py``, not assumed.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from aamcore.config import data_root
from aamcore.pose.align import align_points
from aamcore.pose.errors import PoseError
from aamcore.pose.mesh import Mesh, lift_frontal, surrey_ibug_vertices, surrey_reference_mesh
from aamcore.pose.posit import Posit

_r = range
IBUG68_SUBSETS: dict[str, tuple[int, ...]] = {
    "all": tuple(_r(68)),
    "no_inner_mouth": tuple(_r(60)),
    "no_jaw": tuple(_r(17, 68)),
    "no_mouth": tuple(_r(48)),
    "no_jaw_inner_mouth": tuple(_r(17, 60)),
    "no_jaw_mouth": tuple(_r(17, 48)),
    "eyes_nose": tuple(_r(27, 48)),
    "no_lower_jaw_mouth": tuple(_r(0, 4)) + tuple(_r(13, 48)),
    "chin_no_jaw_sides": (8,) + tuple(_r(17, 68)),
    "chin_no_jaw_sides_inner_mouth": (8,) + tuple(_r(17, 60)),
}
"""Named iBUG-68 subsets (0-16 jaw, 17-26 brows, 27-35 nose, 36-47 eyes, 48-67 mouth)."""

# IMM Frontal markup: 0-15 brows, 16-31 eyes, 32-33 pupils, 34-44 nose,
# 45 nose tip, 46-55 outer mouth, 56-61 inner lips, 62-72 jaw (ear to ear).
IMM73_SUBSETS: dict[str, tuple[int, ...]] = {
    "all": tuple(_r(73)),
    "no_inner_mouth": tuple(_r(56)) + tuple(_r(62, 73)),
    "no_jaw": tuple(_r(62)),
    "no_mouth": tuple(_r(46)) + tuple(_r(62, 73)),
    "no_jaw_mouth": tuple(_r(46)),
    "no_jaw_inner_mouth": tuple(_r(56)),
}
"""Named IMM-73 subsets, by the AAM-API paths of the markup."""

RECOMMENDED_SUBSET: dict[str, str] = {"ibug68": "no_inner_mouth", "imm73": "no_inner_mouth"}
"""Subset used for ``rigid_subset=True``, chosen by ``bench/bench_posit.py``
("rigid subsets": Surrey faces with identity and expression variation, 1 px
noise, jaw points sliding along the face outline as the head turns, 1000
poses). Leaving out only the inner lips gave the lowest mean angle error for
both schemes, statistically tied with all points: iBUG-68 2.19 deg (all 2.21,
no jaw 2.46, no jaw and inner mouth 2.53); IMM-73 1.96 deg (all 1.98, no jaw
2.33). Leaving out the jaw lowers roll error but raises pitch error more:
the jaw is what fixes pitch. With expression alone (no identity change), the
IMM model does best without jaw and mouth (1.02 against 1.21 deg)."""

SUBSETS: dict[str, dict[str, tuple[int, ...]]] = {"ibug68": IBUG68_SUBSETS, "imm73": IMM73_SUBSETS}


@dataclass(frozen=True, eq=False)
class HeadModel:
    """3D positions of (some of) a landmark scheme's points.

    Attributes
    ----------
    name : str
        What the model is, e.g. ``"openface_mean68"``.
    scheme : str
        Landmark scheme name (``"ibug68"``, ``"imm73"``, ...).
    n_landmarks : int
        Points in the scheme.
    indices : (M,) int array
        Landmarks this model uses, M >= 4.
    points : (M, 3) float64 array
        Their 3D positions, mm, OpenCV axes.
    source : str
        Where the points come from.
    """

    name: str
    scheme: str
    n_landmarks: int
    indices: np.ndarray
    points: np.ndarray
    source: str

    def __post_init__(self) -> None:
        idx = np.asarray(self.indices, dtype=np.int64)
        pts = np.asarray(self.points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) != len(idx):
            raise PoseError(f"head model {self.name}: {len(idx)} indices but points of shape "
                            f"{pts.shape}")
        if idx.size and (idx.min() < 0 or idx.max() >= self.n_landmarks):
            raise PoseError(f"head model {self.name}: index out of range 0..{self.n_landmarks}")
        if not np.all(np.isfinite(pts)):
            raise PoseError(f"head model {self.name}: non-finite coordinates")
        object.__setattr__(self, "indices", idx)
        object.__setattr__(self, "points", pts)

    def subset(self, subset: str | tuple[int, ...] | list[int]) -> HeadModel:
        """The model restricted to a named subset or to listed landmark indices."""
        if isinstance(subset, str):
            table = SUBSETS.get(self.scheme, {})
            if subset not in table:
                raise PoseError(f"no subset {subset!r} for scheme {self.scheme}; known: "
                                f"{sorted(table)}")
            wanted, label = table[subset], subset
        else:
            wanted, label = tuple(int(i) for i in subset), "custom"
        position = {int(i): k for k, i in enumerate(self.indices)}
        missing = [i for i in wanted if i not in position]
        if missing:
            raise PoseError(f"head model {self.name} has no point for landmarks {missing[:10]}")
        rows = [position[i] for i in wanted]
        return HeadModel(f"{self.name}[{label}]", self.scheme, self.n_landmarks,
                         self.indices[rows], self.points[rows], self.source)

    def select(self, landmarks: np.ndarray) -> np.ndarray:
        """The model's points among all the scheme's landmarks.

        Parameters
        ----------
        landmarks : (n_landmarks, 2) array
            All landmarks of one face, in the scheme's order.

        Returns
        -------
        (M, 2) array
        """
        landmarks = np.asarray(landmarks)
        if landmarks.shape[0] != self.n_landmarks:
            raise PoseError(f"head model {self.name} expects {self.n_landmarks} landmarks, got "
                            f"{landmarks.shape[0]}")
        return landmarks[self.indices]

    def posit(self, **options: float) -> Posit:
        """A :class:`Posit` for this model (options as in :class:`Posit`).

        ``max_view_angle_deg`` defaults to 90: a face whose landmarks are seen
        must turn its front toward the camera.
        """
        options.setdefault("max_view_angle_deg", 90.0)
        return Posit(self.points, **options)  # type: ignore[arg-type]


def _with_subset(model: HeadModel, rigid_subset: bool | str) -> HeadModel:
    if rigid_subset is False:
        return model
    if rigid_subset is True:
        if model.scheme not in RECOMMENDED_SUBSET:
            raise PoseError(f"no measured rigid subset for scheme {model.scheme}; name one")
        return model.subset(RECOMMENDED_SUBSET[model.scheme])
    return model.subset(rigid_subset)


def _read_csv_table(path: Path) -> np.ndarray:
    """The numeric rows of a head model CSV file, ``(M, 3)`` or ``(M, 4)``.

    Skips blank lines, ``#`` comments and a non-numeric header line.

    Raises
    ------
    PoseError
        Naming the file and line of an unreadable row, or if the rows are not
        all of 3 or all of 4 numbers.
    """
    rows: list[list[float]] = []
    with path.open(newline="") as handle:
        for line_no, row in enumerate(csv.reader(handle), start=1):
            cells = [c.strip() for c in row if c.strip()]
            if not cells or cells[0].startswith("#"):
                continue
            try:
                rows.append([float(c) for c in cells])
            except ValueError as exc:
                if not rows and line_no <= 2:
                    continue  # a header
                raise PoseError(f"{path}:{line_no}: not numeric: {row}") from exc
    widths = {len(r) for r in rows}
    if not rows or len(widths) != 1 or widths.pop() not in (3, 4):
        raise PoseError(f"{path}: expected rows of 3 (x,y,z) or 4 (index,x,y,z) numbers")
    return np.array(rows)


def _csv_points(table: np.ndarray, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Landmark indices ``(M,)`` and points ``(M, 3)`` of a table from :func:`_read_csv_table`.

    Raises
    ------
    PoseError
        If the indices of a 4-column table are not distinct integers.
    """
    if table.shape[1] == 4:
        indices = table[:, 0].astype(np.int64)
        if not np.array_equal(indices, table[:, 0]) or len(set(indices.tolist())) != len(indices):
            raise PoseError(f"{path}: landmark indices must be distinct integers")
        return indices, table[:, 1:]
    return np.arange(len(table)), table


def load_csv_model(
    path: str | Path,
    scheme: str,
    n_landmarks: int | None = None,
    mm_per_unit: float = 1.0,
    rigid_subset: bool | str = False,
) -> HeadModel:
    """Read a head model from a CSV file.

    Either three columns ``x,y,z`` with row i for landmark i, or four columns
    ``index,x,y,z`` naming the landmark of each row. Lines starting with ``#``
    and a non-numeric header line are skipped. Coordinates must use OpenCV
    axes; the model is moved to the centroid of its points.

    Parameters
    ----------
    path : path
    scheme : str
        Landmark scheme name.
    n_landmarks : int, optional
        Points in the scheme (default: one more than the largest index).
    mm_per_unit : float
        Millimetres per file unit.
    rigid_subset : bool or str
        False (all points), True (the measured recommended subset of the
        scheme) or a subset name.

    Raises
    ------
    PoseError
        Naming the file and line for unreadable rows, mixed column counts,
        repeated indices, or fewer than 4 points.
    """
    path = Path(path)
    if not path.is_file():
        raise PoseError(f"{path}: head model file not found")
    indices, points = _csv_points(_read_csv_table(path), path)
    if len(points) < 4:
        raise PoseError(f"{path}: {len(points)} points; POSIT needs at least 4")
    n = int(indices.max()) + 1 if n_landmarks is None else int(n_landmarks)
    points = points * mm_per_unit
    points = points - points.mean(axis=0)
    model = HeadModel(path.stem, scheme, n, indices, points, str(path))
    return _with_subset(model, rigid_subset)


def openface68(rigid_subset: bool | str = False) -> HeadModel:
    """The OpenFace mean 3D shape of the iBUG-68 markup (mm, OpenCV axes)."""
    path = data_root() / "models3d" / "openface_mean68" / "mean68_mm.csv"
    model = load_csv_model(path, "ibug68", 68)
    model = HeadModel("openface_mean68", "ibug68", 68, model.indices, model.points, str(path))
    return _with_subset(model, rigid_subset)


# IMM landmarks used to place the IMM mean shape on the Surrey mesh, with the
# iBUG-68 landmark (0-based) that marks the same spot: outer and inner eye
# corners, mouth corners, chin.
_IMM_ANCHORS: dict[int, int] = {16: 36, 20: 39, 28: 42, 24: 45, 46: 48, 52: 54, 67: 8}


def _imm_mean_shape(folder: Path) -> np.ndarray:
    """Similarity-aligned mean of the IMM annotations in pixels of the first image, (73, 2)."""
    from aamcore.io import load_annotated_folder

    shapes = [s.points for s in load_annotated_folder(folder).samples]
    if not shapes or len(shapes[0]) != 73:
        raise PoseError(f"{folder}: no 73-point IMM annotations")
    mean = shapes[0]
    for _ in range(5):
        aligned = [align_points(s, mean).apply(s) for s in shapes]
        new_mean = np.mean(aligned, axis=0)
        new_mean = align_points(new_mean, shapes[0]).apply(new_mean)
        if np.max(np.abs(new_mean - mean)) < 1e-6:
            break
        mean = new_mean
    return mean


def _closest_on_polyline(xy: np.ndarray, line: np.ndarray) -> np.ndarray:
    """For each 2D point, the 3D point of a polyline whose x-y is nearest, (M, 3).

    Parameters
    ----------
    xy : (M, 2) array
    line : (L, 3) array
        Polyline vertices; segments join consecutive vertices.
    """
    a, b = line[:-1], line[1:]
    ab = b[:, :2] - a[:, :2]
    t = np.einsum("mld,ld->ml", xy[:, None, :] - a[None, :, :2], ab) / np.sum(ab * ab, axis=1)
    t = np.clip(t, 0.0, 1.0)
    foot = a[None] + t[..., None] * (b - a)[None]  # (M, L-1, 3)
    d2 = np.sum((foot[..., :2] - xy[:, None, :]) ** 2, axis=2)
    return foot[np.arange(len(xy)), np.argmin(d2, axis=1)]


@lru_cache(maxsize=2)
def _imm73_points(folder: str) -> tuple[np.ndarray, np.ndarray]:
    ref = openface68().points
    mesh = surrey_reference_mesh()
    vertex_of = surrey_ibug_vertices(len(mesh.vertices))
    ibug = sorted(vertex_of)
    to_ref = align_points(mesh.vertices[[vertex_of[i] for i in ibug]], ref[ibug])
    mesh = Mesh(to_ref.apply(mesh.vertices), mesh.triangles, mesh.uvs, mesh.name)
    mean2d = _imm_mean_shape(Path(folder))
    imm_idx = list(_IMM_ANCHORS)
    to_ref2d = align_points(mean2d[imm_idx], ref[[_IMM_ANCHORS[i] for i in imm_idx], :2])
    xy = to_ref2d.apply(mean2d)
    surface = lift_frontal(mesh, xy)
    points = surface.positions(mesh)
    jaw = np.arange(62, 73)
    points[jaw] = _closest_on_polyline(xy[jaw], ref[:17])
    on_surface = surface.on_surface.copy()
    on_surface[jaw] = True
    # Keep the IMM population's x-y (the mean shape); only depth comes from the references.
    points[:, :2] = xy
    return points, on_surface


def imm73(rigid_subset: bool | str = False, imm_folder: str | Path | None = None) -> HeadModel:
    """A 73-point 3D model of the IMM Frontal markup, in the frame of :func:`openface68`.

    There is no published 3D model of this markup, and no one-to-one map from
    its points to the iBUG-68 ones (its eye, brow and mouth contours are
    sampled differently and it has pupils). The model is built instead:

    1. the similarity-aligned mean of the 120 IMM annotations gives every
       point's frontal x-y;
    2. a 2D similarity fitted on seven anchors (outer and inner eye corners,
       mouth corners, chin: iBUG 36, 39, 42, 45, 48, 54, 8) places that mean
       shape on the frontal view of the OpenFace mean68 model, in mm;
    3. depth: the Surrey reference mesh, aligned to OpenFace by a 3D
       similarity on the iBUG points that ``ibug_to_sfm.txt`` maps, gives each
       brow, eye, pupil, nose and mouth point the depth of the first surface
       seen at its x-y; the 11 jaw points are outline points, not surface
       points, and take the depth of the nearest point (in x-y) of the OpenFace
       jaw outline (iBUG 0-16).

    So x-y are the IMM subjects' mean proportions and z a mean face's depth,
    and the origin is OpenFace's, so that both models give the same ``T`` for
    the same head. Expect the errors of a generic model, a few mm.

    Parameters
    ----------
    rigid_subset : bool or str
        As in :func:`load_csv_model`.
    imm_folder : path, optional
        The IMM Frontal folder (default ``<data>/imm_frontal``).
    """
    folder = Path(imm_folder) if imm_folder is not None else data_root() / "imm_frontal"
    points, on_surface = _imm73_points(str(folder.resolve()))
    off = np.flatnonzero(~on_surface).tolist()
    source = (f"IMM mean shape of {folder} placed on openface_mean68, depth from the Surrey "
              "reference mesh and the OpenFace jaw outline"
              + (f"; points {off} outside the mesh, nearest-vertex depth" if off else ""))
    model = HeadModel("imm73_surrey", "imm73", 73, np.arange(73), points.copy(), source)
    return _with_subset(model, rigid_subset)


def head_model_named(name: str, exact: HeadModel | None = None) -> HeadModel:
    """A head model by name: ``openface68``, ``openface68-rigid``, ``imm73``, ``exact`` (the
    model ``exact`` given, e.g. a synthetic sequence's own) or a ``.csv`` file of 68 points.

    Raises
    ------
    ValueError
        For another name, or ``exact`` without a model.
    """
    if name == "openface68":
        return openface68()
    if name == "openface68-rigid":
        return openface68(rigid_subset=True)
    if name == "imm73":
        return imm73()
    if name == "exact" and exact is not None:
        return exact
    if Path(name).suffix.lower() == ".csv":
        return load_csv_model(Path(name), "ibug68", 68)
    raise ValueError(f"unknown model {name!r}: openface68, openface68-rigid, imm73, exact or a "
                     ".csv")
