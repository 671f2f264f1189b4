"""Synthetic 68-point iBUG faces and images for the face-feature tests."""

from __future__ import annotations

import cv2
import numpy as np

from aamcore.expression.analysis import observe
from aamcore.expression.classifier_file import ExpressionClassifier
from aamcore.expression.crop import FaceObservation
from aamcore.expression.face_classifier import fit_face_classifier
from aamcore.expression.spec import FeatureConfig, PipelineSpec


def _ellipse(cx: float, cy: float, rx: float, ry: float, n: int, start: float, stop: float
             ) -> np.ndarray:
    t = np.linspace(start, stop, n)
    return np.stack([cx + rx * np.cos(t), cy + ry * np.sin(t)], axis=1)


def unit_face() -> np.ndarray:
    """A frontal 68-point face (68, 2) with eye centres at (-0.5, 0) and (0.5, 0)."""
    jaw = _ellipse(0.0, 0.2, 0.95, 1.1, 17, np.pi, 0.0)  # lower half, left to right
    arc = 0.05 * np.sin(np.linspace(0, np.pi, 5))
    brow_l = np.stack([np.linspace(-0.85, -0.2, 5), -0.35 - arc], 1)
    brow_r = brow_l[::-1] * [-1, 1]
    nose_bridge = np.stack([np.zeros(4), np.linspace(0.0, 0.45, 4)], 1)
    nose_base = np.stack([np.linspace(-0.2, 0.2, 5), np.full(5, 0.55)], 1)
    eye_l = _ellipse(-0.5, 0.0, 0.18, 0.07, 7, np.pi, -np.pi)[:-1]
    eye_r = _ellipse(0.5, 0.0, 0.18, 0.07, 7, np.pi, -np.pi)[:-1]
    mouth_out = _ellipse(0.0, 0.85, 0.4, 0.15, 13, np.pi, -np.pi)[:-1]
    mouth_in = _ellipse(0.0, 0.85, 0.25, 0.05, 9, np.pi, -np.pi)[:-1]
    points = np.vstack([jaw, brow_l, brow_r, nose_bridge, nose_base, eye_l, eye_r, mouth_out,
                        mouth_in])
    assert points.shape == (68, 2)
    return points


def place(points: np.ndarray, scale: float, angle_deg: float, centre: tuple[float, float]
          ) -> np.ndarray:
    """Rotate, scale and move canonical points (N, 2) into an image; (N, 2)."""
    a = np.radians(angle_deg)
    R = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    return scale * points @ R.T + np.asarray(centre)


def face_image(points: np.ndarray, size: tuple[int, int] = (240, 320), seed: int = 0
               ) -> np.ndarray:
    """A grey image (H, W) uint8 with a textured face drawn at the landmarks."""
    rng = np.random.default_rng(seed)
    image = rng.integers(90, 110, size=size).astype(np.uint8)
    pts = np.round(points).astype(np.int32)
    cv2.fillPoly(image, [cv2.convexHull(pts)], 170)
    for group in (range(17, 22), range(22, 27), range(36, 42), range(42, 48), range(48, 60)):
        cv2.polylines(image, [pts[list(group)]], True, 40, 2)
    return image


def observation(scale: float = 60.0, angle: float = 0.0, centre: tuple[float, float] = (160.0,
                110.0), seed: int = 0, appearance: np.ndarray | None = None) -> FaceObservation:
    """A synthetic frontal face in a 320 x 240 grey frame, with 5 appearance parameters."""
    points = place(unit_face(), scale, angle, centre)
    c = np.arange(5.0) if appearance is None else appearance
    return FaceObservation.from_arrays(face_image(points, seed=seed), points, c)


def expressive_face(kind: str, person: float) -> np.ndarray:
    """A face (68, 2) of one 'person' (eye-to-mouth length) with a mouth 'expression':
    ``NE``, ``HA`` (wide) or ``SU`` (open)."""
    face = unit_face()
    face[48:68, 1] += person  # people differ in where the mouth is
    mouth = face[48:68]
    centre = mouth.mean(0)
    if kind == "HA":
        face[48:68, 0] = centre[0] + 1.4 * (mouth[:, 0] - centre[0])
    elif kind == "SU":
        face[48:68, 1] = centre[1] + 2.5 * (mouth[:, 1] - centre[1])
    return face


def expression_observation(kind: str, person: float, landmarks: np.ndarray | None = None
                           ) -> FaceObservation:
    """A frame of :func:`expressive_face` (or of ``landmarks``) with 3 appearance parameters."""
    points = place(expressive_face(kind, person), 60.0, 0.0, (160.0, 110.0))
    points = points if landmarks is None else landmarks
    return FaceObservation.from_arrays(face_image(points), points, np.zeros(3))


def stream_classifier(min_count: int = 3, absolute: bool = False) -> ExpressionClassifier:
    """An LDA of relative shape features of three synthetic people (classes NE, HA, SU);
    its stream reference is ready after ``min_count`` faces. With ``absolute``, also the
    person-independent LDA of the absolute features (the deployed pipeline's pair)."""
    config = FeatureConfig(blocks=("shape",))
    rng = np.random.default_rng(0)
    kinds, people = ["NE", "HA", "SU"] * 4, [-0.1, 0.0, 0.1]
    X, A, y, g = [], [], [], []
    for person in people:
        faces = [expression_observation(k, person) for k in kinds]
        vectors = observe(faces, config).vectors(config.blocks)
        vectors += rng.normal(0.0, 0.01, vectors.shape)
        A.append(vectors)
        X.append(vectors - np.median(vectors, axis=0))
        y += kinds
        g += [str(person)] * len(kinds)
    labels, groups = np.array(y), np.array(g)
    fitted = fit_face_classifier(np.vstack(X), labels, groups, {"shape": 136})
    spec = PipelineSpec(config, appearance_dim=3, template=unit_face(),
                        reference={"window": 10, "stride": 1, "min_count": min_count})
    person_independent = (fit_face_classifier(np.vstack(A), labels, groups, {"shape": 136})
                          if absolute else None)
    return ExpressionClassifier.from_face_classifier(fitted, spec, "model",
                                                     absolute=person_independent)
