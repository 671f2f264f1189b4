"""The AAM appearance of given landmarks, for the methods that find landmarks without the AAM.

The local-binary method finds landmarks without sampling the face's texture;
the fitter then gets the AAM's view of the face here, in one pass: one texture
warp over the reference frame's box (the face and a margin around it, from the
grey region the landmarks were found in where it holds the face), projected on the
texture model, with the shape parameters of the landmarks, into the combined
parameters ``c``; the per-pixel texture residual ``g - g_model(c)`` of eq.
6.19, as the AAM methods leave it after their last iteration; and, given an
occlusion test, each landmark's occlusion flag from the same buffers
(:mod:`aamcore.fitting.occlusion`). Every product is float32 (the texture is
8-bit, its normalised values need no more), and ``c`` is float64.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from aamcore.fitting.occlusion import Discs, OcclusionTest, box_of
from aamcore.fitting.residuals import per_pixel
from aamcore.model.aam import AAM
from aamcore.model.similarity import Placement, Similarity


@dataclass(frozen=True)
class Projection:
    """The appearance of a face at given landmarks.

    Attributes
    ----------
    c : (t_c,) float64 array
        Combined appearance parameters.
    texture : (M C,) float32 array
        The normalised texture sampled.
    residual : (M,) float32 array
        ``g - g_model(c)`` per reference-frame pixel (see
        :attr:`aamcore.fitting.result.AAMFit.residual`).
    error : float
        Mean squared residual.
    similarity : Similarity
        The placement of ``c``'s shape on the landmarks (least squares).
    occluded : (N,) bool array or None
        The landmarks whose part of the face is covered or outside the image (None
        without an occlusion test).
    """

    c: np.ndarray
    texture: np.ndarray
    residual: np.ndarray
    error: float
    similarity: Similarity
    occluded: np.ndarray | None = None


ROI_MARGIN = 2
"""Pixels around the landmarks' box that a bilinear sample inside their hull may read."""


@dataclass(frozen=True)
class GreyRegion:
    """A grey (uint8, H x W) part of a frame whose top-left pixel is ``origin`` (x, y)."""

    pixels: np.ndarray
    origin: tuple[int, int]


class AppearanceSampler:
    """Appearance ``c``, texture residual and occlusion flags of an AAM at landmarks.

    Parameters
    ----------
    aam : AAM
    occlusion : OcclusionTest, optional
        Flags the covered landmarks of every projection.
    warp : callable, optional
        The fitter's warp: its ``record(path, seconds)``, where it has one, counts the
        sampler's warps with the fitter's own.

    Notes
    -----
    The texture is sampled on the CPU, over the frame's box (:func:`box_of`: the face and a
    margin around it) in one ``cv2.remap`` of a few thousand pixels, from the grey region
    the landmarks were found in: the GL worker would first upload the whole frame for this
    one warp (it serves the AAM methods' iterations, many warps of one uploaded frame).
    """

    def __init__(self, aam: AAM, occlusion: OcclusionTest | None = None,
                 warp: object | None = None) -> None:
        self.aam = aam
        self.occlusion = occlusion
        self.box = occlusion.discs.box if occlusion is not None else box_of(aam)
        self.record = getattr(warp, "record", None)
        self.channels = aam.channels
        self.texture_mean = aam.texture.mean.astype(np.float32)
        # model texture = mean + Q c; c = x S + (g - mean) Q + c0 with x the landmarks in the
        # model frame: the shape part (w b_s - mu_s) C_s with b_s = (x - mean_s) Phi_s, the
        # texture part (b_g - mu_g) C_g with b_g = Phi_g^T (g - mean), Q = Phi_g C_g
        self._basis = np.ascontiguousarray(aam.texture_basis, np.float32)
        combined, shape = aam.combined, aam.shape
        n_s = shape.n_modes
        components, mean = combined.pca.components, combined.pca.mean
        to_c = combined.weight * shape.pca.components @ components[:n_s]
        self._shape_to_c = to_c
        self._c0 = (-(shape.pca.mean @ to_c) - mean[:n_s] @ components[:n_s]
                    - mean[n_s:] @ components[n_s:])
        self._place = Placement(shape.mean_shape)
        self._discs: Discs | None = None

    def project(self, prepared: np.ndarray, points: np.ndarray,
                bounds: tuple[float, float, float, float] | None = None) -> Projection:
        """The appearance at landmarks ``points`` (N, 2) of an image prepared for the AAM
        (:meth:`aamcore.model.aam.AAM.prepare_image`); ``bounds`` ``(x0, y0, x1, y1)``:
        where the whole frame lies in its coordinates (the image's own by default), for
        the landmarks outside it."""
        found, seen = self._sample(prepared, points)
        if self.occlusion is None:
            return found
        height, width = prepared.shape[:2]
        x0, y0, x1, y1 = bounds or (0.0, 0.0, width - 1.0, height - 1.0)
        outside = ((points[:, 0] < x0) | (points[:, 0] > x1) | (points[:, 1] < y0)
                   | (points[:, 1] > y1))
        occluded = self.occlusion(self._features(found, seen), outside)
        return Projection(found.c, found.texture, found.residual, found.error,
                          found.similarity, occluded)

    def features(self, prepared: np.ndarray, points: np.ndarray) -> np.ndarray:
        """The occlusion test's features (N, F) at landmarks ``points`` (N, 2) of a prepared
        image (:class:`~aamcore.fitting.occlusion.Discs`)."""
        return self._features(*self._sample(prepared, points))

    def _features(self, found: Projection, seen: np.ndarray) -> np.ndarray:
        if self._discs is None:
            self._discs = (self.occlusion.discs if self.occlusion is not None
                           else Discs.of(self.aam, self.box))
        g = found.texture
        inside = g if self.channels == 1 else g.reshape(-1, self.channels).mean(axis=1)
        return self._discs(seen, inside, found.residual, found.error)

    def _sample(self, prepared: np.ndarray, points: np.ndarray) -> tuple[Projection, np.ndarray]:
        """The projection (no flags) and the box normalised as the texture (H, W)."""
        begun = time.perf_counter()
        sampled = self.box.sample(prepared, points)
        if self.record is not None:
            self.record("cpu", time.perf_counter() - begun)
        box = np.asarray(sampled, np.float32)
        if self.channels == 1:
            g = box.ravel()[self.box.inside]
        else:
            g = box.reshape(-1, self.channels)[self.box.inside].ravel()
            box = box.mean(axis=2)
        shift = float(np.add.reduce(g) / g.size)  # g.mean()'s arithmetic, float32
        g -= shift
        std = float(np.sqrt(g @ g / g.size))
        scale = 1.0 / std if std > 1e-6 else 1.0
        g *= scale
        box -= shift
        box *= scale
        sim = self._place.onto(points)
        a, b, s2 = sim.a, sim.b, sim.a * sim.a + sim.b * sim.b
        model = (points - [sim.tx, sim.ty]) @ np.array([[a, -b], [b, a]]) / s2
        d = g - self.texture_mean
        c = model.ravel() @ self._shape_to_c + self._c0 + (d @ self._basis).astype(np.float64)
        residual = d - self._basis @ c.astype(np.float32)
        error = float(residual @ residual) / residual.size
        return Projection(c, g, per_pixel(residual, self.channels), error, sim), box

    def project_frame(self, image: np.ndarray, points: np.ndarray,
                      grey: GreyRegion | None = None) -> Projection:
        """:meth:`project` on a raw frame: only the face's box is read (the landmarks' box
        grown by the box's margin), from ``grey`` (a grey part of the frame already
        converted, when it holds that box) or converted here (a model that equalises the
        face gets the whole frame)."""
        height, width = image.shape[:2]
        a, b = self._place.ab(points).tolist()
        reach = ROI_MARGIN + self.box.margin * math.hypot(a, b)
        lo = np.floor(points.min(axis=0) - reach).astype(int)
        hi = np.ceil(points.max(axis=0) + reach).astype(int) + 1
        x0, y0 = max(int(lo[0]), 0), max(int(lo[1]), 0)
        x1, y1 = min(int(hi[0]), width), min(int(hi[1]), height)
        if x1 - x0 < 2 or y1 - y0 < 2 or self.aam.equalise:
            # outside the frame, or equalised over a region of its own
            return self.project(self.aam.prepare_image(image, points), points)
        box = None
        if grey is not None and self.channels == 1:
            gx, gy = grey.origin
            gh, gw = grey.pixels.shape[:2]
            # the region may be cut by the frame's edge as the box is
            if gx <= x0 and gy <= y0 and x1 <= gx + gw and y1 <= gy + gh:
                box, x0, y0 = grey.pixels, gx, gy
        if box is None:
            # a contiguous copy: OpenCV converts a strided view three times slower
            box = self.aam.prepare_image(np.ascontiguousarray(image[y0:y1, x0:x1]))
        shift = np.array([x0, y0], np.float64)
        found = self.project(box, points - shift, (-x0, -y0, width - 1.0 - x0,
                                                   height - 1.0 - y0))
        sim = found.similarity
        return Projection(found.c, found.texture, found.residual, found.error,
                          Similarity(sim.a, sim.b, sim.tx + x0, sim.ty + y0), found.occluded)

    def __call__(self, image: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, float]:
        """``c`` (t_c,) and the texture error of landmarks ``points`` (N, 2) on a raw
        ``image`` (prepared for the AAM here)."""
        found = self.project(self.aam.prepare_image(image, points), points)
        return found.c, found.error
