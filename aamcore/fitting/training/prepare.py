"""Training a fitting model: everything the algorithms learn, on top of a trained AAM.

The default model (:func:`default_model_path`) is trained on the training
splits of LFPW, HELEN and AFW (:data:`aamcore.defaults.MODEL_DATASET`) with
their mirror images: the local-binary cascade on every face, the AAM and what
the AAM methods learn on a subset (:data:`aamcore.defaults.MODEL_AAM_IMAGES`),
the occlusion test on faces outside that subset, so that it trains in a few
minutes on two cores.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from aamcore import defaults
from aamcore.config import cache_dir
from aamcore.detection.boxes import landmark_box
from aamcore.detection.mapping import BoxToShapeMapping, fit_box_to_shape
from aamcore.fitting.algorithm.local_binary import BinaryCascade
from aamcore.fitting.model import FittingModel
from aamcore.fitting.training.binary import BinaryTrainConfig, train_binary_cascade
from aamcore.fitting.training.data import (
    DetectedFace,
    detect_faces,
    no_face_frames,
    training_set,
)
from aamcore.fitting.training.descent import train_descent
from aamcore.fitting.training.faces import prepare_faces
from aamcore.fitting.training.occlusion import OcclusionTrainConfig, train_occlusion
from aamcore.fitting.training.update import scheme_for_level, train_update
from aamcore.io import FaceSample
from aamcore.io.landmarks import IBUG68_MIRROR
from aamcore.model.aam import AAM
from aamcore.model.cache import cache_key, cached_file
from aamcore.model.training import TrainConfig, train_aam
from aamcore.progress import bar as progress_bar
from aamcore.progress import note, phase, plan
from aamcore.reproducible import one_blas_thread

RECIPE = "fitting v15"
"""Names the training below in the cache key: change it when the training changes."""
MIRRORS = {"ibug68": IBUG68_MIRROR}
"""The left-right permutation of each markup that has one (mirroring needs it)."""
BINARY = BinaryTrainConfig()
"""The local-binary recipe of the models trained here."""
OCCLUSION = OcclusionTrainConfig()
"""The occlusion test's recipe of the models trained here."""
AAM_CONFIG = TrainConfig(colour=False, shape_variance=0.98, n_pixels=2_500)
"""The AAM's recipe: grey textures over about 2,500 reference pixels (a frame about 58 x 60,
for a face about as wide as an eye's part of the face is 9 pixels: what the appearance ``c``,
its residual and the occlusion test read; 10,000 pixels cost four times the warp and the
products for the same flags and expression rows)."""
PHASES = (("appearance model", 3.0), ("face detection", 15.0), ("update matrices, level 0", 3.0),
          ("update matrices, level 1", 3.0), ("descent stages", 22.0),
          ("coarse HOG stages", 29.0), ("fern stages", 61.0), ("restart stages", 38.0),
          ("occlusion test", 60.0))
"""The phases of training the default model, in order, with their seconds on a quiet
two-core machine (their shares as measured on a loaded one, 1668 s in all, scaled to the
201 s of a quiet one, for recipe fitting v12; ``bench/bench_prepare.py`` measures them):
what "phase k of n" and the time left are reckoned from (:func:`aamcore.progress.plan`)."""

Bar = Callable[[str], Callable[[Iterable[Any]], Iterable[Any]]]


def _no_bar(desc: str) -> Callable[[Iterable[Any]], Iterable[Any]]:
    return lambda items: items


def _sized(wrap: Callable[[Iterable[Any]], Iterable[Any]], total: int
           ) -> Callable[[Iterable[Any]], Iterable[Any]]:
    """``wrap`` given ``total`` (a bar shows a percentage only when it knows the length)."""

    class Sized:
        def __init__(self, items: Iterable[Any]) -> None:
            self.items = items

        def __iter__(self):
            return iter(self.items)

        def __len__(self) -> int:
            return total

    return lambda items: wrap(Sized(items))


def subset(samples: Sequence[FaceSample], n: int | None) -> list[FaceSample]:
    """At most ``n`` of ``samples``, evenly spread over them (all for None)."""
    if not n or n >= len(samples):
        return list(samples)
    step = len(samples) / n
    return [samples[int(k * step)] for k in range(n)]


@one_blas_thread
def train_fitting_model(
    aam: AAM,
    samples: list[FaceSample],
    method: str = "jacobian",
    max_images: int | None = 60,
    descent_stages: int = 5,
    pyramid_levels: int = 2,
    bar: Bar | None = None,
    binary: BinaryTrainConfig | None = BINARY,
    mirror: bool = True,
    aam_images: int | None = None,
    occlusion: OcclusionTrainConfig | None = OCCLUSION,
) -> FittingModel:
    """Train what fitting ``aam`` needs, from training ``samples``.

    That is the box-to-shape mapping (from detections on every sample), the
    update matrices of the fixed-Jacobian fitter (``method``, on at most
    ``max_images`` images, one per pyramid level), the supervised-descent
    cascade (on at most ``aam_images`` samples) and, unless ``binary`` is None,
    the local-binary cascade on every sample (and its mirror image, where
    ``mirror`` and the markup has a permutation, :data:`MIRRORS`), and unless
    ``occlusion`` is None the occlusion test, on the samples the AAM was not
    trained on (all of them when fewer than 50 are left).
    ``bar(desc)`` shows the progress of each phase (:func:`aamcore.progress.bar`).
    """
    bar = bar or _no_bar
    detected = detect_faces(samples, binary.n_jobs if binary else 2,
                            progress=_sized(bar("face detection"), len(samples)))
    mapping = fit_box_to_shape(aam.shape.mean_shape, [s.points for s in samples],
                               [d.boxes for d in detected])
    chosen = subset(range(len(samples)), aam_images)  # type: ignore[arg-type]
    few = [samples[k] for k in chosen]
    updates = [
        train_update(aam, few, method, scheme_for_level(level), max_images, level=level,
                     progress=bar(f"update matrices, level {level}"))
        for level in range(pyramid_levels)
    ]
    cascade = train_descent(aam, few, [detected[k].box for k in chosen], mapping,
                            stages=descent_stages, progress=bar("descent stages"))
    cascade_binary = None
    if binary is not None:
        permutation = MIRRORS.get(aam.scheme.name) if mirror else None
        cascade_binary = binary_cascade(aam, samples, detected, mapping, binary, permutation,
                                        bar)
        aam.summary["fit_images"] = [s.image_id() for s in samples]
    occlusion_part = None
    if occlusion is not None:
        used = set(chosen)
        unseen = [s for k, s in enumerate(samples) if k not in used]
        with phase("occlusion test"):
            occlusion_part = train_occlusion(aam, unseen if len(unseen) >= 50 else samples,
                                             regressor_landmarks(aam, mapping, cascade_binary),
                                             occlusion)
    return FittingModel(aam, mapping, updates, cascade, cascade_binary, occlusion_part)


def regressor_landmarks(aam: AAM, mapping: BoxToShapeMapping, cascade: BinaryCascade | None):
    """How the stack places a training face's landmarks: the local-binary method from the
    mean shape on the face's landmark box (None without a cascade)."""
    if cascade is None:
        return None
    from aamcore.fitting.algorithm.local_binary import LocalBinary

    method = LocalBinary(cascade, aam)

    def landmarks(image, truth):
        start = mapping.place(landmark_box(truth), "landmarks")
        return method.fit_shape(method.prepare(image), start).points

    return landmarks


def binary_cascade(aam: AAM, samples: Sequence[FaceSample], detected: Sequence[DetectedFace],
                   mapping: BoxToShapeMapping, config: BinaryTrainConfig, mirror, bar: Bar
                   ) -> BinaryCascade:
    """The local-binary cascade of ``samples``, each started as the fitter starts it: the
    AAM's mean shape on its detection through ``mapping`` (the landmark box where the
    detector missed it)."""
    starts = [mapping.place(d.box, "detector") if d.box is not None
              else mapping.place(landmark_box(s.points), "landmarks")
              for s, d in zip(samples, detected, strict=True)]
    faces = prepare_faces([d.grey for d in detected], [d.factor for d in detected],
                          [s.points for s in samples], starts,
                          [d.box is not None for d in detected], mirror)
    return train_binary_cascade(faces, config, no_face_frames(), bar, aam.scheme.eye_corners)


def build_fitting_model(
    dataset: str = defaults.MODEL_DATASET,
    config: TrainConfig | None = None,
    max_images: int = defaults.MODEL_UPDATE_IMAGES,
    limit: int | None = None,
    aam_images: int | None = defaults.MODEL_AAM_IMAGES,
    mirror: bool = True,
    binary: BinaryTrainConfig | None = BINARY,
    update_method: str = "jacobian",
) -> FittingModel:
    """Train a fitting model on the training faces of ``dataset`` (see :func:`default_model_path`),
    with a progress bar per long phase."""
    start = time.perf_counter()
    data = training_set(dataset, limit)
    for error in data.errors:  # a bad or missing annotation is named, never silently used
        note(f"skipped: {error}")
    config = config or AAM_CONFIG
    few = subset(data.samples, aam_images)
    note(f"training a fitting model on {len(data.samples)} faces of {data.name} (the "
         f"appearance model on {len(few)})")
    with plan("training the fitting model", PHASES):
        aam = train_aam(few, data.scheme, config, progress=progress_bar("appearance model"),
                        source=f"{dataset} [{f'first {limit}' if limit else 'training split'}]")
        model = train_fitting_model(aam, data.samples, update_method, max_images,
                                    bar=progress_bar, binary=binary, mirror=mirror,
                                    aam_images=aam_images)
    note(f"fitting model trained in {time.perf_counter() - start:.0f} s")
    return model


def default_model_path(
    dataset: str = defaults.MODEL_DATASET,
    config: TrainConfig | None = None,
    max_images: int = defaults.MODEL_UPDATE_IMAGES,
    limit: int | None = None,
    aam_images: int | None = defaults.MODEL_AAM_IMAGES,
    update_method: str = "jacobian",
) -> Path:
    """Path of a cached fitting model, trained on first use (the stack's model by default).

    Parameters
    ----------
    dataset : str
        Comma-separated dataset names or folders; ``lfpw``, ``helen`` and
        ``afw`` give their training split only (:mod:`aamcore.io.splits`).
        The 68-point iBUG markup is what the head-pose model expects.
    config : TrainConfig, optional
        The AAM's (:data:`AAM_CONFIG` by default).
    max_images : int
        Images used to learn the update matrices.
    limit : int, optional
        Train on the first ``ceil(limit / folders)`` faces of each folder only
        (small models for tests).
    aam_images : int, optional
        Faces the AAM and the supervised-descent cascade are trained on (spread
        over the training faces); the local-binary cascade learns from all.
    update_method : {"jacobian", "regression"}
        How the update matrices are learned (Algorithm 6 or 5).
    """
    config = config or AAM_CONFIG
    data = training_set(dataset, limit)
    chosen = f"first {limit}" if limit else "all"
    extra = {"select": chosen, "split": data.split, "aam_images": aam_images,
             "prepare": f"{RECIPE}, {max_images} images", "binary": BINARY.to_json(),
             "occlusion": asdict(OCCLUSION)}
    if update_method != "jacobian":
        extra["update"] = update_method
    key = cache_key(",".join(str(f) for f in data.folders), config, extra)

    def build(path: Path) -> Path:
        note(f"the fitting model is trained once and kept in {path.parent}")
        model = build_fitting_model(dataset, config, max_images, limit, aam_images,
                                    update_method=update_method)
        return model.save(path)

    return cached_file(cache_dir() / f"{data.name}-{key}.npz", build, FittingModel.load)
