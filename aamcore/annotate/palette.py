"""The colours of a face's drawing, shared by the annotated video and the Rerun logger:
facial parts, occluded landmarks, failed fits, faces by id. RGB throughout."""

from __future__ import annotations

from aamcore.io.landmarks import LandmarkScheme

PART_COLOURS: dict[str, tuple[int, int, int]] = {
    "brows": (255, 150, 20),
    "eyes": (30, 190, 255),
    "nose": (60, 220, 90),
    "mouth": (235, 90, 200),
    "jaw": (240, 220, 80),
}
"""Colour of each facial part."""
PARTS = tuple(PART_COLOURS)
"""The facial parts, in the order the Rerun logger numbers their classes."""
OTHER_COLOUR = (200, 200, 200)
"""Colour of the parts of other schemes and of points in no part."""
FAILED_COLOUR = (235, 60, 50)
"""Every landmark of a fit that failed its failure test."""
OCCLUDED_COLOUR = (255, 0, 255)
"""Landmarks covered by something: magenta rings over their part's colour."""
FACE_COLOURS = ((80, 200, 120), (80, 160, 255), (255, 170, 60), (200, 110, 255),
                (255, 90, 140), (60, 220, 220), (220, 220, 80), (150, 150, 150))
"""Each face's colour (its id modulo the count): its box and label."""
NO_PART = "points"
"""The part of the points of a scheme that names no groups (or of points in none)."""

_GROUP_ORDER = ("jaw", "brows", "nose", "eyes", "mouth")
"""Coarse groups first: a point takes the first group that holds it."""


def point_groups(scheme: LandmarkScheme) -> list[str]:
    """The group of each landmark (coarse groups first), ``"points"`` for none; ``(n_points,)``."""
    order = [g for g in _GROUP_ORDER if g in scheme.groups]
    order += [g for g in scheme.groups if g not in order]
    group_of: dict[int, str] = {}
    for group in order:
        for i in scheme.groups[group]:
            group_of.setdefault(i, group)
    return [group_of.get(i, NO_PART) for i in range(scheme.n_points)]


def point_colours(scheme: LandmarkScheme) -> list[tuple[int, int, int]]:
    """The colour of each landmark, by its part; ``(n_points,)``."""
    return [PART_COLOURS.get(group, OTHER_COLOUR) for group in point_groups(scheme)]


def face_colour(face_id: int) -> tuple[int, int, int]:
    """The colour of face ``face_id`` (-1, no face: the first)."""
    return FACE_COLOURS[max(face_id, 0) % len(FACE_COLOURS)]
