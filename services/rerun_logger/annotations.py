"""Landmark classes for Rerun: the points of a face coloured by facial part.

Rerun draws keypoint colours, labels and connections from an
``AnnotationContext``. Each landmark scheme gets

- one class per facial part (brows, eyes, nose, mouth, jaw for iBUG-68, in
  that order; a scheme without named groups has one part, ``points``): a
  good fit's points carry the class id of their part, so the viewer colours
  them by part, with the part's edges as ``keypoint_connections``;
- one class for failed fits, holding every point and edge: a failed fit is
  drawn in one colour, whatever the part.

Keypoint ids are the landmark indices in every class, labelled with their
group, e.g. ``"jaw 3"``. An edge between points of two parts is drawn only
in the failed class (iBUG-68 has none: each of its edges lies in one part).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import rerun as rr

from aamcore.annotate.palette import (
    FAILED_COLOUR,
    OTHER_COLOUR,
    PART_COLOURS,
    PARTS,
    point_groups,
)
from aamcore.io.landmarks import IBUG68, LandmarkScheme

KNOWN_SCHEMES: dict[str, LandmarkScheme] = {IBUG68.name: IBUG68}
"""Schemes whose connectivity is known by name; others are drawn as loose points."""


def resolve_scheme(name: str, n_points: int) -> LandmarkScheme:
    """The scheme a fit names, or a scheme without edges if the name or count is unknown.

    Parameters
    ----------
    name : str
        ``Fit.scheme``, e.g. ``"ibug68"``.
    n_points : int
        Number of landmarks the fit holds.
    """
    known = KNOWN_SCHEMES.get(name)
    if known is not None and known.n_points == n_points:
        return known
    return LandmarkScheme(name, n_points, ())


def keypoint_labels(scheme: LandmarkScheme) -> list[str]:
    """One label per landmark: its group and index, e.g. ``"jaw 3"``; ``(n_points,)``."""
    return [f"{group} {i}" for i, group in enumerate(point_groups(scheme))]


def scheme_parts(scheme: LandmarkScheme) -> list[str]:
    """The parts a scheme's points fall in: :data:`PARTS` first, then its other groups."""
    present = set(point_groups(scheme))
    return [p for p in PARTS if p in present] + sorted(present - set(PARTS))


def class_description(
    scheme: LandmarkScheme,
    class_id: int,
    label: str,
    colour: tuple[int, int, int],
    points: list[int] | None = None,
) -> rr.ClassDescription:
    """A Rerun class of some of a scheme's landmarks (all by default) and the edges among them."""
    labels = keypoint_labels(scheme)
    keep = set(range(scheme.n_points)) if points is None else set(points)
    return rr.ClassDescription(
        info=rr.AnnotationInfo(id=class_id, label=label, color=colour),
        keypoint_annotations=[
            rr.AnnotationInfo(id=i, label=labels[i]) for i in sorted(keep)
        ],
        keypoint_connections=[(a, b) for a, b in scheme.edges if a in keep and b in keep],
    )


@dataclass(frozen=True)
class SchemeClasses:
    """The classes of one scheme.

    Attributes
    ----------
    scheme : LandmarkScheme
    part_ids : (n_points,) int array
        Class id of each landmark of a good fit: the id of its part.
    failed_id : int
        Class id of every landmark of a failed fit.
    descriptions : list of rerun.ClassDescription
        Its part classes, then its failed class.
    """

    scheme: LandmarkScheme
    part_ids: np.ndarray
    failed_id: int
    descriptions: list[rr.ClassDescription]

    def ids(self, failed: bool = False) -> np.ndarray:
        """Class id of each landmark, ``(n_points,)``."""
        if failed:
            return np.full(self.scheme.n_points, self.failed_id, dtype=np.uint16)
        return self.part_ids


def scheme_classes(scheme: LandmarkScheme, first_id: int, label: str) -> SchemeClasses:
    """The part classes and the failed class of a scheme, numbered from ``first_id``."""
    groups = point_groups(scheme)
    parts = scheme_parts(scheme)
    descriptions = []
    for k, part in enumerate(parts):
        points = [i for i, g in enumerate(groups) if g == part]
        colour = PART_COLOURS.get(part, OTHER_COLOUR)
        descriptions.append(
            class_description(scheme, first_id + k, f"{label} {part}", colour, points))
    failed_id = first_id + len(parts)
    descriptions.append(class_description(scheme, failed_id, f"{label}, failed", FAILED_COLOUR))
    part_ids = np.array([first_id + parts.index(g) for g in groups], dtype=np.uint16)
    return SchemeClasses(scheme, part_ids, failed_id, descriptions)


class LandmarkClasses:
    """Class ids of landmark schemes, assigned as schemes appear.

    Each new ``(scheme, point count)`` takes the next free class ids: one per
    part, then one for failed fits (iBUG-68, seen first: brows 0, eyes 1,
    nose 2, mouth 3, jaw 4, failed 5). :meth:`context` returns the
    annotation context of all schemes seen so far; log it again whenever
    :meth:`class_ids` reports a new scheme.
    """

    def __init__(self) -> None:
        self._schemes: dict[tuple[str, int], SchemeClasses] = {}
        self._next_id = 0

    def classes(self, name: str, n_points: int) -> tuple[SchemeClasses, bool]:
        """The classes of a scheme, and whether the scheme is new."""
        key = (name, n_points)
        found = self._schemes.get(key)
        if found is not None:
            return found, False
        made = scheme_classes(resolve_scheme(name, n_points), self._next_id,
                              f"{name} ({n_points} points)")
        self._schemes[key] = made
        self._next_id = made.failed_id + 1
        return made, True

    def class_ids(self, name: str, n_points: int, failed: bool = False) -> tuple[np.ndarray, bool]:
        """The class id of each of a fit's landmarks, and whether the scheme is new.

        Parameters
        ----------
        name : str
            Scheme name.
        n_points : int
            Number of landmarks.
        failed : bool
            Whether the fit failed.

        Returns
        -------
        class_ids : (n_points,) int array
            The id of each point's part, or the failed class's for a failed fit.
        is_new : bool
            True the first time this ``(name, n_points)`` is seen.
        """
        classes, is_new = self.classes(name, n_points)
        return classes.ids(failed), is_new

    def context(self) -> rr.AnnotationContext:
        """The annotation context of every scheme seen so far."""
        return rr.AnnotationContext(
            [d for classes in self._schemes.values() for d in classes.descriptions])
