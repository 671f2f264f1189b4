"""A 3D glasses model built in code and placed on the mean head (thesis section 15.2).

Millimetres in the head model's frame: the OpenFace mean iBUG-68 shape
(``models3d/openface_mean68``), OpenCV axes (+x right, +y down, +z away from
a camera the face looks at), origin at the centroid of the 68 points, the
frame in which POSIT's pose ``X_cam = R X + T`` is expressed.

The glasses are two lens rims (tubes swept along rounded rectangles), two
flat lenses, a bridge arching over the nose and two temples running back
past the sides of the head and bending down behind the ears. They are placed
from landmarks: each lens is centred on its eye (the mid-point of the eye
corners, iBUG 36/39 and 42/45), the lens plane stands in front of the nose
bridge (iBUG 27), and the temples run just outside the jaw's widest points
(iBUG 0 and 16, which sit near the ears).

"Right" and "left" are the wearer's: the right lens is over iBUG 36-41, at -x.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from aamcore.ar.mesh_primitives import TriMesh, concatenate, fan, superellipse, tube

RIGHT_EYE_CORNERS = (36, 39)
LEFT_EYE_CORNERS = (42, 45)
NOSE_BRIDGE = 27
JAW_ENDS = (0, 16)

ANCHOR_NAMES = ("lens_right", "lens_left", "bridge", "hinge_right", "hinge_left")
"""Anchor points of :class:`GlassesMesh`, the order of :meth:`GlassesMesh.anchor_points`."""

OPAQUE_PARTS = ("rim_right", "rim_left", "bridge", "temple_right", "temple_left")
LENS_PARTS = ("lens_right", "lens_left")


@dataclass(frozen=True)
class GlassesDesign:
    """Sizes of the glasses, in millimetres.

    Attributes
    ----------
    lens_half_width, lens_half_height : float
        Half sizes of a lens.
    lens_roundness : float
        Superellipse exponent of the lens outline (2: ellipse; 4: rounded rectangle).
    rim_radius, bridge_radius, temple_radius : float
        Tube radii.
    clearance : float
        Distance from the nose bridge landmark to the lens plane, toward the camera.
    bridge_rise : float
        How far the bridge arches above the line joining its ends.
    temple_margin : float
        Gap between a temple and the jaw's widest landmark, sideways.
    temple_length : float
        Depth (along +z) from the lens plane to the top of the ear, where the temple bends.
    temple_drop : float
        How far the temple's end bends down behind the ear.
    """

    lens_half_width: float = 25.0
    lens_half_height: float = 18.0
    lens_roundness: float = 3.5
    rim_radius: float = 1.6
    bridge_radius: float = 1.4
    temple_radius: float = 1.5
    clearance: float = 10.0
    bridge_rise: float = 4.0
    temple_margin: float = 6.0
    temple_length: float = 105.0
    temple_drop: float = 25.0


@dataclass(frozen=True, eq=False)
class GlassesMesh:
    """The glasses as one mesh whose triangles are grouped into named parts.

    Attributes
    ----------
    mesh : TriMesh
        Vertices (V, 3) mm, normals (V, 3), triangles (F, 3).
    parts : dict of str to (int, int)
        ``(first triangle, triangle count)`` of each part: :data:`OPAQUE_PARTS`
        then :data:`LENS_PARTS`, contiguous in that order.
    lens_centres : (2, 3) array
        Centres of the right and left lenses, mm.
    anchors : dict of str to (3,) array
        Points that place the glasses on the face, mm: ``lens_right``,
        ``lens_left`` (lens centres), ``bridge`` (top of the bridge),
        ``hinge_right``, ``hinge_left`` (where the temples leave the rims).
        Where they are drawn measures a head pose for AR: their pixel error
        is what a viewer sees.
    """

    mesh: TriMesh
    parts: dict[str, tuple[int, int]] = field(default_factory=dict)
    lens_centres: np.ndarray = field(default_factory=lambda: np.zeros((2, 3)))
    anchors: dict[str, np.ndarray] = field(default_factory=dict)

    def anchor_points(self) -> np.ndarray:
        """The anchors as one (5, 3) array in :data:`ANCHOR_NAMES` order, mm."""
        return np.array([self.anchors[name] for name in ANCHOR_NAMES])

    @property
    def vertices(self) -> np.ndarray:
        return self.mesh.vertices

    @property
    def normals(self) -> np.ndarray:
        return self.mesh.normals

    @property
    def triangles(self) -> np.ndarray:
        return self.mesh.triangles

    def part_vertices(self, name: str) -> np.ndarray:
        """Vertices (K, 3) used by the triangles of part ``name``."""
        first, count = self.parts[name]
        used = np.unique(self.mesh.triangles[first : first + count])
        return self.mesh.vertices[used]


def _lens_outline(centre: np.ndarray, design: GlassesDesign, n: int = 64) -> np.ndarray:
    """Lens outline (n, 3) in the plane z = centre z."""
    curve = superellipse(
        design.lens_half_width, design.lens_half_height, design.lens_roundness, n
    )
    return np.column_stack([curve + centre[:2], np.full(n, centre[2])])


def _outline_point(
    centre: np.ndarray, design: GlassesDesign, side: float, rise_deg: float
) -> np.ndarray:
    """Point of a lens outline toward ``side`` (+1: +x) and ``rise_deg`` above horizontal."""
    theta = np.radians(rise_deg)
    power = 2.0 / design.lens_roundness
    c, s = np.cos(theta), np.sin(theta)
    x = side * design.lens_half_width * c**power
    y = -design.lens_half_height * s**power  # OpenCV +y is down
    return centre + np.array([x, y, 0.0])


def _bezier(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray, n: int) -> np.ndarray:
    t = np.linspace(0.0, 1.0, n)[:, None]
    return (1 - t) ** 2 * p0 + 2 * (1 - t) * t * p1 + t**2 * p2


def _catmull_rom(points: np.ndarray, per_segment: int) -> np.ndarray:
    """A smooth curve through ``points`` (K, 3), (per_segment (K-1) + 1, 3)."""
    padded = np.vstack([2 * points[0] - points[1], points, 2 * points[-1] - points[-2]])
    t = np.linspace(0.0, 1.0, per_segment, endpoint=False)[:, None]
    out = []
    for i in range(1, len(padded) - 2):
        p0, p1, p2, p3 = padded[i - 1 : i + 3]
        out.append(
            0.5 * (2 * p1 + (-p0 + p2) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t**2
                   + (-p0 + 3 * p1 - 3 * p2 + p3) * t**3)
        )
    out.append(points[-1:])
    return np.vstack(out)


def _temple_path(
    hinge: np.ndarray, side: float, half_spacing: float, design: GlassesDesign
) -> np.ndarray:
    """Temple centre line (K, 3) from the hinge back past the ear and down."""
    z0 = hinge[2]
    x = side * half_spacing
    controls = np.array([
        hinge,
        [hinge[0] + side * 2.0, hinge[1], z0 + 6.0],
        [x, hinge[1] + 1.0, z0 + 30.0],
        [x, hinge[1] + 3.0, z0 + design.temple_length],
        [x - side * 2.0, hinge[1] + design.temple_drop, z0 + design.temple_length + 22.0],
    ])
    return _catmull_rom(controls, 12)


def build_glasses(landmarks: np.ndarray, design: GlassesDesign | None = None) -> GlassesMesh:
    """Glasses fitted to a 3D iBUG-68 head shape.

    Parameters
    ----------
    landmarks : (68, 3) array
        The head shape, mm, OpenCV axes (e.g. the OpenFace mean shape).
    design : GlassesDesign, optional

    Raises
    ------
    ValueError
        For landmarks that are not (68, 3) finite values.
    """
    design = design or GlassesDesign()
    landmarks = np.asarray(landmarks, dtype=np.float64)
    if landmarks.shape != (68, 3) or not np.all(np.isfinite(landmarks)):
        raise ValueError(f"landmarks must be a finite (68, 3) iBUG shape, got {landmarks.shape}")
    lens_z = landmarks[NOSE_BRIDGE, 2] - design.clearance
    centres = []
    for corners in (RIGHT_EYE_CORNERS, LEFT_EYE_CORNERS):
        eye = landmarks[list(corners)].mean(axis=0)
        centres.append(np.array([eye[0], eye[1], lens_z]))
    right, left = centres
    half_spacing = np.abs(landmarks[list(JAW_ENDS), 0]).max() + design.temple_margin

    meshes: dict[str, TriMesh] = {}
    for name, centre in (("right", right), ("left", left)):
        outline = _lens_outline(centre, design)
        meshes[f"rim_{name}"] = tube(outline, design.rim_radius, closed=True)
        meshes[f"lens_{name}"] = fan(outline + [0.0, 0.0, 0.5], np.array([0.0, 0.0, -1.0]))
    inner_right = _outline_point(right, design, +1.0, 25.0)
    inner_left = _outline_point(left, design, -1.0, 25.0)
    top = 0.5 * (inner_right + inner_left) + [0.0, -2.0 * design.bridge_rise, -2.0]
    bridge = _bezier(inner_right, top, inner_left, 16)
    meshes["bridge"] = tube(bridge, design.bridge_radius)
    anchors = {"lens_right": right, "lens_left": left, "bridge": bridge[len(bridge) // 2]}
    for name, centre, side in (("right", right, -1.0), ("left", left, 1.0)):
        hinge = _outline_point(centre, design, side, 20.0) + [side * design.rim_radius, 0, 0]
        anchors[f"hinge_{name}"] = hinge
        path = _temple_path(hinge, side, half_spacing, design)
        meshes[f"temple_{name}"] = tube(path, design.temple_radius, sides=10)

    order = OPAQUE_PARTS + LENS_PARTS
    parts, first = {}, 0
    for name in order:
        parts[name] = (first, meshes[name].n_triangles)
        first += meshes[name].n_triangles
    mesh = concatenate([meshes[name] for name in order])
    return GlassesMesh(mesh, parts, np.array(centres), anchors)


def mean_head_glasses(design: GlassesDesign | None = None) -> GlassesMesh:
    """Glasses on the OpenFace mean head (``models3d/openface_mean68``), POSIT's frame."""
    from aamcore.pose.head_model import openface68

    return build_glasses(openface68().points, design)
