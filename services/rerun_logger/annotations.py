"""Landmark classes for Rerun: one class per (scheme, point count) and fit state.

Rerun draws keypoint connections and labels from an ``AnnotationContext``:
each class has keypoints (here: the landmarks, labelled by their group) and
``keypoint_connections`` (here: the scheme's edges). A good fit and a failed
fit of one scheme get two classes, so the viewer colours them apart.
"""

from __future__ import annotations

import rerun as rr

from aamcore.io.landmarks import IBUG68, LandmarkScheme

GOOD_COLOUR = (40, 220, 90)
FAILED_COLOUR = (235, 60, 50)
KNOWN_SCHEMES: dict[str, LandmarkScheme] = {IBUG68.name: IBUG68}
"""Schemes whose connectivity is known by name; others are drawn as loose points."""

# Coarse groups first: a point takes the first group that holds it.
_GROUP_ORDER = ("jaw", "brows", "nose", "eyes", "mouth")


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
    order = [g for g in _GROUP_ORDER if g in scheme.groups]
    order += [g for g in scheme.groups if g not in order]
    group_of: dict[int, str] = {}
    for group in order:
        for i in scheme.groups[group]:
            group_of.setdefault(i, group)
    return [f"{group_of.get(i, 'point')} {i}" for i in range(scheme.n_points)]


def class_description(
    scheme: LandmarkScheme, class_id: int, label: str, colour: tuple[int, int, int]
) -> rr.ClassDescription:
    """A Rerun class whose keypoints are the scheme's landmarks, connected by its edges."""
    return rr.ClassDescription(
        info=rr.AnnotationInfo(id=class_id, label=label, color=colour),
        keypoint_annotations=[
            rr.AnnotationInfo(id=i, label=text) for i, text in enumerate(keypoint_labels(scheme))
        ],
        keypoint_connections=list(scheme.edges),
    )


class LandmarkClasses:
    """Class ids of landmark schemes, assigned as schemes appear.

    Scheme ``k`` (in order of first use) has class ``2 k`` for good fits and
    ``2 k + 1`` for failed ones. :meth:`context` returns the annotation context
    of all schemes seen so far; log it again whenever :meth:`class_id` reports
    a new scheme.
    """

    def __init__(self) -> None:
        self._schemes: dict[tuple[str, int], LandmarkScheme] = {}

    def class_id(self, name: str, n_points: int, failed: bool = False) -> tuple[int, bool]:
        """The class of a fit's landmarks, and whether the scheme is new.

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
        class_id : int
        is_new : bool
            True the first time this ``(name, n_points)`` is seen.
        """
        key = (name, n_points)
        is_new = key not in self._schemes
        if is_new:
            self._schemes[key] = resolve_scheme(name, n_points)
        return 2 * list(self._schemes).index(key) + int(failed), is_new

    def context(self) -> rr.AnnotationContext:
        """The annotation context of every scheme seen so far (two classes each)."""
        classes = []
        for k, ((name, n), scheme) in enumerate(self._schemes.items()):
            label = f"{name} ({n} points)"
            classes.append(class_description(scheme, 2 * k, label, GOOD_COLOUR))
            classes.append(class_description(scheme, 2 * k + 1, f"{label}, failed", FAILED_COLOUR))
        return rr.AnnotationContext(classes)
