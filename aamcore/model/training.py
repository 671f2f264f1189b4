"""Train an :class:`~aamcore.model.aam.AAM` from annotated images (thesis chapters 3-5)."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass

import numpy as np

from aamcore.io import DatasetError, FaceSample
from aamcore.io.landmarks import LandmarkScheme
from aamcore.model.aam import AAM
from aamcore.model.combined import CombinedModel
from aamcore.model.procrustes import generalised_procrustes
from aamcore.model.shape import ShapeModel
from aamcore.model.texture import TextureModel
from aamcore.reproducible import one_blas_thread
from aamcore.warp.reference_frame import ReferenceFrame, delaunay_triangles, scale_for_pixels

MIN_IMAGES = 3


@dataclass(frozen=True)
class TrainConfig:
    """Options of :func:`train_aam`.

    Attributes
    ----------
    shape_variance, texture_variance, combined_variance : float
        Fractions of the variance each PCA keeps (eq. 3.16).
    n_pixels : int
        Approximate number of pixels inside the reference frame.
    colour : bool
        Sample BGR colour (True) or grey (False).
    equalise : bool
        Histogram-equalise the face region per channel before sampling.
    """

    shape_variance: float = 0.95
    texture_variance: float = 0.95
    combined_variance: float = 0.95
    n_pixels: int = 10_000
    colour: bool = True
    equalise: bool = False


class TrainingError(ValueError):
    """Training cannot proceed; the message says why."""


def _check_rank(name: str, n_modes: int, n_images: int, variance: float) -> None:
    if n_modes >= n_images - 1:
        raise TrainingError(
            f"the {name} model needs all {n_modes} modes that {n_images} images allow to keep "
            f"{variance:.1%} of the variance: give more images or ask for less variance"
        )


def _check_samples(samples: list[FaceSample], scheme: LandmarkScheme) -> None:
    if len(samples) < MIN_IMAGES:
        raise TrainingError(f"{len(samples)} images: training needs at least {MIN_IMAGES}")
    bad = [s for s in samples if s.points.shape != (scheme.n_points, 2)]
    if bad:
        raise TrainingError(
            f"{bad[0].image_path}: {len(bad[0].points)} points, scheme {scheme.name} has "
            f"{scheme.n_points}"
        )


def _shape_and_frame(
    samples: list[FaceSample], config: TrainConfig
) -> tuple[ShapeModel, ReferenceFrame]:
    """The shape model of ``samples`` and the reference frame of its mean shape."""
    shapes = np.stack([s.points for s in samples])
    _, unit_mean, _ = generalised_procrustes(shapes)
    triangles = delaunay_triangles(unit_mean)
    scale = scale_for_pixels(unit_mean, triangles, config.n_pixels)
    shape_model = ShapeModel.train(shapes, config.shape_variance, scale)
    return shape_model, ReferenceFrame.from_mean_shape(shape_model.mean_shape, triangles)


def _sample_textures(
    samples: list[FaceSample],
    scheme: LandmarkScheme,
    shape_model: ShapeModel,
    frame: ReferenceFrame,
    config: TrainConfig,
    progress: Callable[[Iterable[FaceSample]], Iterable[FaceSample]] | None,
) -> tuple[list[np.ndarray], list[FaceSample], list[str]]:
    """Sample the texture of every readable image of ``samples`` in ``frame``.

    Returns
    -------
    textures : list of (M C,) float32 arrays
        Normalised textures, ``M = frame.n_pixels``, ``C`` the channels.
    kept : list of FaceSample
        The samples whose image could be read, in their order.
    skipped : list of str
        One message per unreadable image.
    """
    channels = 3 if config.colour else 1
    # The texture model is not known yet: an AAM shell gives the sampling.
    shell = AAM(
        scheme,
        shape_model,
        TextureModel(shape_model.pca, channels),
        None,
        frame,  # type: ignore[arg-type]
        equalise=config.equalise,
    )
    textures, kept, skipped = [], [], []
    for sample in (progress or iter)(samples):
        try:
            image = shell.prepare_image(sample.load_image(), sample.points)
        except DatasetError as exc:
            skipped.append(str(exc))
            continue
        textures.append(shell.sample(image, sample.points).astype(np.float32))
        kept.append(sample)
    return textures, kept, skipped


@dataclass(frozen=True)
class _Sampled:
    """The readable images' textures, sampled in the frame built from those images.

    Attributes
    ----------
    shape_model : ShapeModel
        Trained on the ``n`` kept images.
    frame : ReferenceFrame
        The reference frame of its mean shape.
    textures : (n, M C) float32 array
        The kept images' normalised textures, sampled in ``frame``.
    kept : list of FaceSample
        The readable samples, in their order.
    skipped : list of str
        One message per unreadable image.
    """

    shape_model: ShapeModel
    frame: ReferenceFrame
    textures: np.ndarray
    kept: list[FaceSample]
    skipped: list[str]


def _sample_in_final_frame(
    samples: list[FaceSample],
    scheme: LandmarkScheme,
    config: TrainConfig,
    progress: Callable[[Iterable[FaceSample]], Iterable[FaceSample]] | None,
) -> _Sampled:
    """Build the frame from the readable images and sample their textures in it.

    The frame is first built from all ``samples``. If some images cannot be
    read, shape model and frame are rebuilt from the others and their textures
    sampled again, so that every texture comes from the final frame.
    """
    kept, skipped = list(samples), []
    while True:
        shape_model, frame = _shape_and_frame(kept, config)
        textures, readable, failed = _sample_textures(
            kept, scheme, shape_model, frame, config, progress
        )
        skipped += failed
        if len(readable) < MIN_IMAGES:
            raise TrainingError(
                f"only {len(readable)} readable images: training needs at least {MIN_IMAGES}"
            )
        if not failed:
            return _Sampled(shape_model, frame, np.stack(textures), readable, skipped)
        kept = readable


def _check_texture_length(texture: TextureModel, frame: ReferenceFrame) -> None:
    """The invariant of an AAM: one texture value per frame pixel and channel."""
    if texture.mean.size != frame.n_pixels * texture.channels:
        raise AssertionError(
            f"texture length {texture.mean.size} != {frame.n_pixels} frame pixels x "
            f"{texture.channels} channels: textures were sampled in another frame"
        )


@one_blas_thread
def train_aam(
    samples: list[FaceSample],
    scheme: LandmarkScheme,
    config: TrainConfig = TrainConfig(),
    progress: Callable[[Iterable[FaceSample]], Iterable[FaceSample]] | None = None,
    source: str = "",
) -> AAM:
    """Build shape, texture and combined models from ``samples``.

    Images that cannot be read are reported in ``summary["skipped"]`` and left
    out; training goes on while at least :data:`MIN_IMAGES` remain. The models
    and the reference frame are then those of the remaining images alone.

    Parameters
    ----------
    samples : list of FaceSample
    scheme : LandmarkScheme
    config : TrainConfig
    progress : callable, optional
        Wraps the sample iteration, e.g. ``tqdm`` (once more if images were skipped).
    source : str
        Where the samples came from, for the summary.

    Raises
    ------
    TrainingError
        Too few good images, or too few for the variance asked.
    """
    _check_samples(samples, scheme)
    sampled = _sample_in_final_frame(samples, scheme, config, progress)
    shape_model, kept, n = sampled.shape_model, sampled.kept, len(sampled.kept)
    _check_rank("shape", shape_model.n_modes, n, config.shape_variance)
    channels = 3 if config.colour else 1
    texture_model = TextureModel.train(sampled.textures, config.texture_variance, channels)
    _check_rank("texture", texture_model.n_modes, n, config.texture_variance)
    b_s = np.stack([shape_model.fit_points(s.points)[0] for s in kept])
    b_g = texture_model.params(sampled.textures.astype(np.float64))
    combined = CombinedModel.train(
        b_s, b_g, shape_model.pca.variances, texture_model.pca.variances, config.combined_variance
    )
    _check_rank("combined", combined.n_modes, n, config.combined_variance)
    summary = {
        "source": source,
        "images": n,
        "subjects": len({s.subject for s in kept if s.subject is not None}),
        "train_subjects": sorted({s.subject for s in kept if s.subject is not None}),
        "train_images": [s.image_id() for s in kept],
        "skipped": sampled.skipped,
        "config": asdict(config),
    }
    _check_texture_length(texture_model, sampled.frame)
    return AAM(
        scheme, shape_model, texture_model, combined, sampled.frame, config.equalise, summary
    )
