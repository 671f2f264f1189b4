"""Synthetic faces with exact landmarks, and a small AAM of them: fast algorithm tests.

Each face is drawn by OpenCV from its 16 landmarks (a skin-toned outline with
dark eyes, brows and mouth, on a textured background) under a random
similarity and a random deformation, so that a model trained on 40 of them
knows the variation that the held-out ones show.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import pytest

from aamcore.detection.boxes import landmark_box
from aamcore.detection.mapping import BoxMapping, BoxToShapeMapping
from aamcore.io import FaceSample
from aamcore.io.landmarks import generic_scheme
from aamcore.model.aam import AAM
from aamcore.model.training import TrainConfig, train_aam

SIZE = 160
TEMPLATE = np.array(
    [[-30, -10], [-22, 20], [0, 34], [22, 20], [30, -10],  # outline
     [-16, -8], [-8, -8], [8, -8], [16, -8],  # eye corners
     [-18, -20], [18, -20],  # brows
     [0, 6],  # nose
     [-10, 18], [0, 15], [10, 18], [0, 22]],  # mouth
    dtype=np.float64)


@dataclass(frozen=True)
class SyntheticFaces:
    """Training and held-out synthetic faces, and their landmark scheme."""

    train: list[FaceSample]
    test: list[FaceSample]
    scheme: object


def draw_face(points: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A grey-level face (SIZE, SIZE, 3) uint8 drawn at ``points`` (16, 2)."""
    image = rng.integers(60, 110, (SIZE, SIZE), np.uint8)
    image = cv2.GaussianBlur(image, (0, 0), 2.0)
    outline = points[[0, 1, 2, 3, 4]]
    top = np.array([points[10] + [8, -14], points[9] + [-8, -14]])
    cv2.fillPoly(image, [np.vstack([outline, top]).round().astype(np.int32)], 190)
    for a, b in ((5, 6), (7, 8), (9, 9), (10, 10)):
        centre = (points[a] + points[b]) / 2
        axes = (int(max(np.linalg.norm(points[a] - points[b]) / 2, 6)), 3)
        cv2.ellipse(image, tuple(centre.round().astype(int)), axes, 0, 0, 360, 40, -1)
    cv2.fillPoly(image, [points[[12, 13, 14, 15]].round().astype(np.int32)], 70)
    cv2.circle(image, tuple(points[11].round().astype(int)), 3, 140, -1)
    return cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)


def face_points(rng: np.random.Generator) -> np.ndarray:
    """Landmarks (16, 2): the template deformed (mouth opening, face width) and placed."""
    shape = TEMPLATE.copy()
    shape[12:16, 1] += rng.normal(0, 2.0) * np.array([0.3, -1.0, 0.3, 1.0])
    shape[:, 0] *= 1 + rng.normal(0, 0.06)
    scale, angle = rng.uniform(1.3, 1.7), rng.normal(0, 0.12)
    c, s = np.cos(angle), np.sin(angle)
    shift = SIZE / 2 + rng.normal(0, 6, 2)
    return shape @ (scale * np.array([[c, -s], [s, c]])).T + shift


@pytest.fixture(scope="session")
def synthetic_faces(tmp_path_factory: pytest.TempPathFactory) -> SyntheticFaces:
    folder: Path = tmp_path_factory.mktemp("synthetic-faces")
    rng = np.random.default_rng(7)
    samples = []
    for k in range(48):
        points = face_points(rng)
        path = folder / f"face_{k:02d}.png"
        cv2.imwrite(str(path), draw_face(points, rng))
        samples.append(FaceSample(path, points))
    return SyntheticFaces(samples[:40], samples[40:], generic_scheme(len(TEMPLATE)))


@pytest.fixture(scope="session")
def synthetic_aam(synthetic_faces: SyntheticFaces) -> AAM:
    """A grey AAM of the synthetic faces, about 1500 reference pixels."""
    config = TrainConfig(n_pixels=1500, colour=False, shape_variance=0.98,
                         texture_variance=0.98, combined_variance=0.98)
    return train_aam(synthetic_faces.train, synthetic_faces.scheme, config)  # type: ignore[arg-type]


@pytest.fixture(scope="session")
def synthetic_mapping(synthetic_aam: AAM, synthetic_faces: SyntheticFaces) -> BoxToShapeMapping:
    """The box-to-shape mapping of landmark boxes (the synthetic faces have no detector)."""
    reference = synthetic_aam.shape.mean_shape
    shapes = np.stack([s.points for s in synthetic_faces.train])
    boxes = np.stack([landmark_box(p) for p in shapes])
    mapping = BoxMapping.fit(reference, boxes, shapes)
    return BoxToShapeMapping(reference, mapping, mapping, 1.0, len(shapes))


def point_error(points: np.ndarray, truth: np.ndarray) -> float:
    """Mean landmark distance in pixels."""
    return float(np.linalg.norm(points - truth, axis=1).mean())


def textured_frames(n: int, size: tuple[int, int] = (120, 160), seed: int = 3) -> list[np.ndarray]:
    """Grey frames (H, W) uint8 of blurred noise and blobs: no face in them."""
    rng = np.random.default_rng(seed)
    frames = []
    for _ in range(n):
        image = cv2.GaussianBlur(rng.integers(0, 255, size, np.uint8), (0, 0), 3.0)
        for _ in range(6):
            centre = tuple(int(v) for v in rng.integers(0, min(size), 2))
            cv2.circle(image, centre, int(rng.integers(4, 20)), int(rng.integers(0, 255)), -1)
        frames.append(image)
    return frames


@pytest.fixture(scope="session")
def synthetic_training_faces(synthetic_faces: SyntheticFaces, synthetic_mapping: BoxToShapeMapping):
    """The synthetic training faces as the local-binary training takes them: grey, started
    from their landmark boxes through the mapping (no detector), no mirror (16 points)."""
    from aamcore.fitting.training.faces import prepare_faces

    train = synthetic_faces.train
    greys = [cv2.cvtColor(s.load_image(), cv2.COLOR_BGR2GRAY) for s in train]
    starts = [synthetic_mapping.place(landmark_box(s.points), "landmarks") for s in train]
    return prepare_faces(greys, [1.0] * len(train), [s.points for s in train], starts,
                         [False] * len(train), None)


@pytest.fixture(scope="session")
def synthetic_binary_config():
    """A small local-binary recipe for the synthetic faces (about a second to train)."""
    from aamcore.fitting.training.binary import BinaryTrainConfig
    from aamcore.fitting.training.ferns import FernConfig
    from aamcore.fitting.training.hog import HogConfig
    from aamcore.fitting.training.quality import QualityConfig

    return BinaryTrainConfig(
        coarse=(HogConfig(24.0, 16), HogConfig(32.0, 16)),
        tracking=(FernConfig(0.3, n_ferns=3), FernConfig(0.15, n_ferns=3)),
        restart=(FernConfig(0.4, n_ferns=3),), restart_starts=3,
        quality=QualityConfig(FernConfig(0.3, n_ferns=2, depth=4), per_face=6, per_no_face=10),
        shape_variance=0.98, n_jobs=1, threshold=-2.0)


@pytest.fixture(scope="session")
def synthetic_binary(synthetic_training_faces, synthetic_binary_config, synthetic_aam):
    """The local-binary cascade of the synthetic faces."""
    from aamcore.fitting.training.binary import train_binary_cascade

    return train_binary_cascade(synthetic_training_faces, synthetic_binary_config,
                                textured_frames(6), eye_corners=synthetic_aam.scheme.eye_corners)
