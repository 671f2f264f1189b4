"""The trained Active Appearance Model as one object.

An :class:`AAM` ties the shape, texture and combined models to the reference
frame and its warp, and offers the operations fitting and display need: model
instances from appearance and pose parameters, texture sampling, and the
parameters of an annotated image.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from aamcore.io.images import to_channels
from aamcore.io.landmarks import LandmarkScheme
from aamcore.model.combined import CombinedModel
from aamcore.model.shape import ShapeModel
from aamcore.model.similarity import Similarity
from aamcore.model.texture import TextureModel, equalise_region, normalise_texture
from aamcore.warp.piecewise_affine import PiecewiseAffineWarp, render_texture
from aamcore.warp.reference_frame import ReferenceFrame


@dataclass
class AAM:
    """A combined shape and texture model with its reference frame.

    Attributes
    ----------
    scheme : LandmarkScheme
    shape : ShapeModel
    texture : TextureModel
    combined : CombinedModel
    frame : ReferenceFrame
    equalise : bool
        Whether images are histogram-equalised over the face region before
        sampling (thesis section 4.3).
    summary : dict
        Training summary stored in the model file header.
    """

    scheme: LandmarkScheme
    shape: ShapeModel
    texture: TextureModel
    combined: CombinedModel
    frame: ReferenceFrame
    equalise: bool = False
    summary: dict[str, Any] = field(default_factory=dict)

    @property
    def channels(self) -> int:
        return self.texture.channels

    @property
    def n_appearance(self) -> int:
        """Number of appearance parameters ``t_c``."""
        return self.combined.n_modes

    @cached_property
    def warp(self) -> PiecewiseAffineWarp:
        """The CPU warp into the reference frame."""
        return PiecewiseAffineWarp(self.frame, self.shape.n_points)

    @cached_property
    def shape_basis(self) -> np.ndarray:
        """``Phi_s W_s^-1 Phi_cs``, (2N, t_c): model-frame shape = mean + basis @ c."""
        return self.shape.pca.components @ self.combined.shape_block

    @cached_property
    def texture_basis(self) -> np.ndarray:
        """``Phi_g Phi_cg``, (M C, t_c): texture = mean + basis @ c."""
        return self.texture.pca.components @ self.combined.texture_block

    def model_shape(self, c: np.ndarray) -> np.ndarray:
        """Model-frame shape (N, 2) of appearance ``c`` (eq. 5.3)."""
        return (self.shape.pca.mean + self.shape_basis @ c).reshape(-1, 2)

    def shape_instance(self, c: np.ndarray, similarity: Similarity) -> np.ndarray:
        """Image shape (N, 2) of appearance ``c`` (t_c,) placed by ``similarity``."""
        return similarity.apply(self.model_shape(c))

    def texture_instance(self, c: np.ndarray) -> np.ndarray:
        """Normalised model texture (M C,) of appearance ``c`` (eq. 5.4)."""
        return self.texture.mean + self.texture_basis @ c

    def prepare_image(self, image: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
        """Convert ``image`` to the model's channels and, if asked, equalise the face."""
        image = to_channels(image, self.channels)
        if self.equalise and points is not None:
            image = equalise_region(image, points)
        return image

    def sample(self, image: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Normalised texture (M C,) of a prepared ``image`` inside ``points`` (N, 2)."""
        g, _, _ = normalise_texture(self.warp.warp(image, points).ravel())
        return g

    def parameters_of(
        self, image: np.ndarray, points: np.ndarray
    ) -> tuple[np.ndarray, Similarity]:
        """Appearance ``c`` (t_c,) and placement of an annotated raw image."""
        b_s, sim = self.shape.fit_points(points)
        g = self.sample(self.prepare_image(image, points), points)
        return self.combined.params(b_s, self.texture.params(g)), sim

    def render(
        self,
        c: np.ndarray,
        similarity: Similarity,
        canvas: np.ndarray,
        alpha: float = 1.0,
        beta: float = 0.0,
    ) -> np.ndarray:
        """Paint the model instance of ``c`` placed by ``similarity`` onto ``canvas`` (figure 5.1).

        ``alpha`` and ``beta`` undo the photometric normalisation
        (``g = alpha g_norm + beta``) so the instance matches an image's
        brightness.
        """
        texture = self.texture_instance(c) * alpha + beta
        texture = np.clip(texture, 0, 255).reshape(self.frame.n_pixels, -1)
        if canvas.ndim == 2:
            texture = texture.mean(axis=1)
        elif texture.shape[1] != canvas.shape[2]:
            texture = np.repeat(texture[:, :1], canvas.shape[2], axis=1)
        return render_texture(self.frame, texture, self.shape_instance(c, similarity), canvas)
