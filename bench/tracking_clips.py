"""The generated sequences of the tracking bench: held-out photos of LFPW, HELEN and AFW
moved, lit, blurred and (every second one) occluded, cached as lossless videos with their
ground truth (see ``bench_tracking.py``); the non-rigid ones also change expression
(:mod:`aamcore.synth.deform`)."""

from __future__ import annotations

import hashlib
import inspect
from dataclasses import dataclass
from pathlib import Path

from aamcore.config import cache_dir, resolve_dataset
from aamcore.evaluation.fits import held_out
from aamcore.fitting import occluders
from aamcore.fitting.model import FittingModel
from aamcore.io import FaceSample, load_annotated_folder
from aamcore.io.splits import split
from aamcore.synth import deform, motion, motion_files
from aamcore.synth.deform import ExpressionSpec, expression_shapes
from aamcore.synth.motion import MotionSpec, generate
from aamcore.synth.motion_files import GroundTruth, read_ground_truth, video_path, write_sequence

SETS = {"lfpw": "lfpw", "helen": "helen/trainset", "afw": "afw"}
"""Split set -> dataset folder."""
SEEDS = {"lfpw": 100, "helen": 200, "afw": 300}
"""First motion seed of each set's sequences."""
NONRIGID_SEED = 1000
"""Added to a set's seed for its non-rigid sequences."""
NONRIGID = " non-rigid"
"""Ends the set name of a set's non-rigid sequences."""
NONRIGID_OTHERS = 2
"""Other held-out faces whose aligned shapes a non-rigid sequence's face blends toward."""
OCCLUDER = (0.4, 0.6)
"""The occluder's crossing, as fractions of the sequence."""


@dataclass(frozen=True)
class Clip:
    """A video to track.

    Attributes
    ----------
    set_name : str
        ``lfpw``, ``helen``, ``afw`` (with :data:`NONRIGID` after it for the non-rigid
        sequences), or ``video`` for the real video.
    name : str
    video : Path
    truth : GroundTruth or None
    """

    set_name: str
    name: str
    video: Path
    truth: GroundTruth | None


def generator_version(nonrigid: bool = False) -> str:
    """A digest of the generator's code: cached sequences are remade when it changes."""
    text = (inspect.getsource(motion) + inspect.getsource(motion_files)
            + inspect.getsource(occluders))
    if nonrigid:
        text += inspect.getsource(deform)
    return hashlib.sha1(text.encode()).hexdigest()[:8]


def held_out_photos(model: FittingModel, set_name: str, count: int,
                    quiet: bool = False) -> list[FaceSample]:
    """``count`` held-out photos of a set, spread over it, that ``model`` was not trained on."""
    data = load_annotated_folder(resolve_dataset(SETS[set_name]))
    _, test = split(data.samples, set_name)
    fresh = held_out(model.aam, test)
    if len(fresh) < len(test) and not quiet:
        print(f"note: {len(test) - len(fresh)} of the {len(test)} held-out {set_name} photos "
              "are in the model's training set: left out")
    if len(fresh) <= count:
        return fresh
    return [fresh[i * len(fresh) // count] for i in range(count)]


def motion_spec(set_name: str, index: int, frames: int) -> MotionSpec:
    """The motion of a set's ``index``-th sequence: an occluder on every second one."""
    occluder = None
    if index % 2 == 1:
        occluder = (int(OCCLUDER[0] * frames), int(OCCLUDER[1] * frames))
    return MotionSpec(frames=frames, occluder=occluder, seed=SEEDS[set_name] + index)


def sequence_folder(set_name: str, sample: FaceSample, spec: MotionSpec) -> Path:
    """Where the sequence of ``sample`` moved by ``spec`` is cached."""
    key = f"{sample.image_id()} {spec} {generator_version()}"
    digest = hashlib.sha1(key.encode()).hexdigest()[:10]
    return cache_dir() / "sequences" / f"{set_name}-{Path(sample.image_path).stem}-{digest}"


def ensure_sequence(set_name: str, sample: FaceSample, spec: MotionSpec,
                    regenerate: bool) -> tuple[Path, GroundTruth]:
    """The cached sequence's folder and truth, generated and written when missing."""
    folder = sequence_folder(set_name, sample, spec)
    if not regenerate:
        try:
            truth = read_ground_truth(folder)
            if truth.spec == spec and video_path(folder).exists():
                return folder, truth
        except (FileNotFoundError, KeyError, ValueError):
            pass
    sequence = generate(sample.load_image(), sample.points, spec)
    write_sequence(sequence, folder, spec=spec)
    return folder, read_ground_truth(folder)


def generated_clips(model: FittingModel, per_set: int, frames: int,
                    regenerate: bool) -> list[Clip]:
    """The generated sequences of every set, ``per_set`` each."""
    clips = []
    for set_name in SETS:
        for k, sample in enumerate(held_out_photos(model, set_name, per_set)):
            spec = motion_spec(set_name, k, frames)
            folder, truth = ensure_sequence(set_name, sample, spec, regenerate)
            label = f"{set_name} {Path(sample.image_path).stem}{' +occl' if spec.occluder else ''}"
            clips.append(Clip(set_name, label, video_path(folder), truth))
    return clips


def nonrigid_spec(set_name: str, index: int, frames: int) -> tuple[MotionSpec, ExpressionSpec]:
    """The motion and expression of a set's ``index``-th non-rigid sequence: smaller rigid
    motion than the rigid sequences', an occluder on every second one."""
    occluder = None
    if index % 2 == 1:
        occluder = (int(OCCLUDER[0] * frames), int(OCCLUDER[1] * frames))
    seed = SEEDS[set_name] + NONRIGID_SEED + index
    return (MotionSpec(frames=frames, max_angle_deg=15.0, scales=(0.85, 1.2), speed=1.0,
                       occluder=occluder, seed=seed), ExpressionSpec(seed=seed))


def nonrigid_clips(model: FittingModel, per_set: int, frames: int,
                   regenerate: bool) -> list[Clip]:
    """The non-rigid sequences of every set, ``per_set`` each: a held-out photo whose face
    changes expression (toward the aligned shapes of the next held-out photos of the set)."""
    clips = []
    for set_name in SETS:
        photos = held_out_photos(model, set_name, per_set * (1 + NONRIGID_OTHERS), quiet=True)
        for k in range(min(per_set, len(photos) // (1 + NONRIGID_OTHERS))):
            sample = photos[k]
            others = [photos[per_set * (1 + j) + k] for j in range(NONRIGID_OTHERS)]
            spec, expression = nonrigid_spec(set_name, k, frames)
            key = (f"{sample.image_id()} {spec} {expression} "
                   f"{[o.image_id() for o in others]} {generator_version(True)}")
            digest = hashlib.sha1(key.encode()).hexdigest()[:10]
            folder = (cache_dir() / "sequences"
                      / f"{set_name}-{Path(sample.image_path).stem}-nonrigid-{digest}")
            truth = None
            if not regenerate:
                try:
                    truth = read_ground_truth(folder)
                    if truth.spec != spec or not video_path(folder).exists():
                        truth = None
                except (FileNotFoundError, KeyError, ValueError):
                    truth = None
            if truth is None:
                shapes = expression_shapes(sample.points, [o.points for o in others], frames,
                                           expression)
                write_sequence(generate(sample.load_image(), sample.points, spec, shapes),
                               folder, spec=spec)
                truth = read_ground_truth(folder)
            label = (f"{set_name} {Path(sample.image_path).stem} nonrigid"
                     f"{' +occl' if spec.occluder else ''}")
            clips.append(Clip(set_name + NONRIGID, label, video_path(folder), truth))
    return clips
