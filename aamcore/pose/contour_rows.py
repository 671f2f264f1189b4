"""The rows of :class:`aamcore.pose.robust.ContourPose`'s Gauss-Newton steps, computed fast.

At each step the refinement needs, at the current pose: each inner point's x and y
reprojection residual, each outline landmark's residual across the outline (against the
silhouette point of its slice of the head, :mod:`aamcore.pose.contour`), the Jacobian of
every residual in the rotation and translation, and the inner points' visibility weights.

The head model fixes most of that work. :class:`ContourRows` does it once: it stacks the
inner points, the outline's frontal points and their outward neighbours and every slice's
candidates (padded to one length, so that the silhouette point of each slice is one
``argmax``) into one homogeneous array, coordinates by rows, so that a step moves all of
them with one product.
:meth:`ContourRows.frame` readies the arrays of one fit's landmarks once; :meth:`ContourRows.at`
fills the rows of a pose. Each row is written ``r = a . (p(P) - o)``: ``p`` the projection of
the camera point ``P`` in normalised coordinates, ``o`` the observed landmark and ``a`` (2,)
the row's direction in pixels (``(fx, 0)`` for an x row, ``(0, fy)`` for a y row, the
outline's normal times the focal lengths for an outline row); its gradient in ``P`` is
``g = (a0, a1, -a . p) / z``, so its Jacobian row is ``(Q x g, g)`` for the rotation update
``R <- exp([w]x) R`` of the point ``Q = R X`` and the translation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aamcore.pose.contour import OutlineModel


@dataclass(frozen=True, eq=False)
class RowFrame:
    """One fit's landmarks as the rows read them (made by :meth:`ContourRows.frame`).

    Attributes
    ----------
    obs : (2, m) array
        Each row's observed landmark, normalised coordinates (0 where not finite).
    direction : (2, m) array
        Each row's ``a``; the outline rows' are set at each pose.
    point : (m,) int array
        Each row's column of :attr:`ContourRows.points`; the outline rows' are set at each
        pose.
    inner_weight : (n,) array
        1 for the inner landmarks inside the frame, else 0.
    outline_weight : (L,) array
        The outline rows' base weights.
    fxy : (2, 1) array
        The focal lengths.
    J : (6, m) array
        The Jacobian, transposed, overwritten at each pose.
    """

    obs: np.ndarray
    direction: np.ndarray
    point: np.ndarray
    inner_weight: np.ndarray
    outline_weight: np.ndarray
    fxy: np.ndarray
    J: np.ndarray


class ContourRows:
    """The residual rows of inner points and sliding outline points under a pose.

    Parameters
    ----------
    inner : (n,) int array
        The inner landmarks (iBUG indices).
    inner_points : (n, 3) array
        Their model points, mm.
    inner_normals : (n, 3) array or None
        Their unit outward surface normals (None: every point fully visible).
    outline : OutlineModel or None
        The outline's slices (None: no outline rows).
    visible_until_deg, hidden_from_deg : float
        The visibility ramp (:func:`aamcore.pose.visibility.visibility_weights`).
    """

    def __init__(self, inner: np.ndarray, inner_points: np.ndarray,
                 inner_normals: np.ndarray | None, outline: OutlineModel | None,
                 visible_until_deg: float = 65.0, hidden_from_deg: float = 90.0) -> None:
        self.n = n = len(inner)
        self.inner = np.asarray(inner, np.int64)
        self.outline = np.zeros(0, np.int64) if outline is None else np.asarray(
            outline.landmarks, np.int64)
        self.L = L = len(self.outline)
        cos_full, cos_zero = np.cos(np.radians([visible_until_deg, hidden_from_deg]))
        scale = 1.0 / (cos_full - cos_zero)
        self._ramp_start = float(cos_zero * scale)
        parts = [np.asarray(inner_points, np.float64)]
        self.width = 0
        if outline is not None:
            starts = np.asarray(outline.starts)
            sizes = np.diff(np.append(starts, len(outline.candidates)))
            self.width = int(sizes.max())
            # Each slice's candidates, its last one repeated up to the longest slice's
            # length: argmax takes the first of equal values, so a repeat is never chosen.
            candidate = starts[:, None] + np.minimum(np.arange(self.width), sizes[:, None] - 1)
            parts += [outline.frontal, outline.frontal + 10.0 * outline.outward,
                      outline.candidates[candidate].reshape(-1, 3)]
        points = np.vstack(parts)
        columns = [np.vstack([points.T, np.ones(len(points))])]
        self.visibility = inner_normals is not None
        if inner_normals is not None:  # directions: the product turns them, no translation
            columns.append(np.vstack([-scale * np.asarray(inner_normals).T, np.zeros(n)]))
        self.points = np.hstack(columns)
        """(4, n + 2 L + L W [+ n]), homogeneous, by rows: the inner points, the frontal
        outline points, 10 mm outward of those, each slice's candidates padded to W [and the
        inner points' inward normals over the visibility ramp's width, as directions]."""
        self._candidates = slice(n + 2 * L, n + 2 * L + L * self.width)
        self._first_candidate = n + 2 * L + self.width * np.arange(L)
        self._row_landmark = np.concatenate([self.inner, self.inner, self.outline])
        self._row_axis = np.zeros((2, 2 * n + L))
        self._row_axis[0, :n] = self._row_axis[1, n:2 * n] = 1.0
        self._row_point = np.concatenate([np.arange(n), np.arange(n), np.zeros(L, np.int64)])

    def frame(self, xy: np.ndarray, inside: np.ndarray, fxy: np.ndarray,
              outline_weight: float) -> RowFrame:
        """The arrays of one fit's rows.

        Parameters
        ----------
        xy : (68, 2) array
            Normalised landmarks (NaN where missing).
        inside : (68,) bool array
            The usable landmarks.
        fxy : (2,) array
            Focal lengths.
        outline_weight : float
            An outline row's weight relative to an inner row's.
        """
        obs = xy[self._row_landmark].T
        if np.isnan(obs).any():
            obs = np.where(np.isnan(obs), 0.0, obs)
        fxy = np.asarray(fxy, np.float64).reshape(2, 1)
        return RowFrame(obs, self._row_axis * fxy, self._row_point.copy(),
                        inside[self.inner].astype(np.float64),
                        outline_weight * inside[self.outline], fxy,
                        np.empty((6, len(self._row_point))))

    def at(self, R: np.ndarray, T: np.ndarray, frame: RowFrame
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Residuals (m,) in pixels, the Jacobian transposed (6, m) and base weights (m,) at
        the pose ``R`` (3, 3), ``T`` (3,); None when a point in use is at or behind the
        camera. The Jacobian is ``frame.J``, overwritten at the next pose."""
        n, L, stop = self.n, self.L, self._candidates.stop
        M = np.empty((3, 4))
        M[:, :3], M[:, 3] = R, T
        P = M @ self.points
        z = P[2, :stop]
        near = z.min() <= 1e-6
        if not near:
            uv = P[:2, :stop] / z
        elif z[:n].min() <= 0.0:
            return None
        else:  # a candidate at or behind the camera: it can only lose
            uv = P[:2, :stop] / np.maximum(z, 1e-6)
        w_in = frame.inner_weight
        if self.visibility:
            w_in = w_in * self._visibility(P[:, :n], P[:, stop:])
        a, point = frame.direction, frame.point
        if L:
            point[2 * n:] = self._silhouette(uv, a[:, 2 * n:], frame.fxy)
        Pr, uvr = P[:, point], uv[:, point]
        if near and Pr[2].min() <= 0.0:
            return None
        J = frame.J
        g = J[3:]
        np.multiply(a, 1.0 / Pr[2], out=g[:2])
        g[2] = -(g[0] * uvr[0] + g[1] * uvr[1])
        Q = Pr - T[:, None]  # the points turned about the model's origin
        J[0] = Q[1] * g[2] - Q[2] * g[1]
        J[1] = Q[2] * g[0] - Q[0] * g[2]
        J[2] = Q[0] * g[1] - Q[1] * g[0]
        d = uvr - frame.obs
        r = d[0] * a[0] + d[1] * a[1]
        return r, J, np.concatenate([w_in, w_in, frame.outline_weight])

    def outline_points(self, frame: RowFrame) -> np.ndarray:
        """The model points (L, 3) the outline landmarks were matched to at the last pose
        :meth:`at` was given with ``frame``."""
        return self.points[:3, frame.point[2 * self.n:]].T

    def _visibility(self, P: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """The inner points' visibility weights (n,) from their camera points ``P`` (3, n)
        and their turned, scaled inward normals (3, n)."""
        ramp = np.add.reduce(normals * P) / np.sqrt(np.add.reduce(P * P))
        ramp -= self._ramp_start
        return np.minimum(np.maximum(ramp, 0.0), 1.0)

    def _silhouette(self, uv: np.ndarray, a: np.ndarray, fxy: np.ndarray) -> np.ndarray:
        """The column (L,) of each slice's point that reaches furthest outward in the image,
        setting ``a`` (2, L) to the outline's outward image normals times the focal lengths."""
        n, L = self.n, self.L
        e = uv[:, n + L:n + 2 * L] - uv[:, n:n + L]
        e *= fxy
        e /= np.maximum(np.sqrt(e[0] * e[0] + e[1] * e[1]), 1e-12)
        np.multiply(e, fxy, out=a)
        reach = np.einsum("dlw,dl->lw", uv[:, self._candidates].reshape(2, L, self.width), a)
        return self._first_candidate + reach.argmax(axis=1)
