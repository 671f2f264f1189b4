"""Drawing a frame's results on it with OpenCV: landmarks coloured by facial part (occluded
ones ringed in magenta, a failed fit's all in red), the head's axes, and a label per face
with its id and expression, or why it has none."""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from aamcore.annotate.palette import FAILED_COLOUR, OCCLUDED_COLOUR, face_colour, point_colours
from aamcore.ar.projection import project_points
from aamcore.face_result import FaceResult
from aamcore.io.landmarks import LandmarkScheme

AXIS_MM = 60.0
"""Length of the head's drawn axes, millimetres (as the Rerun logger draws them)."""
AXIS_COLOURS = ((0, 0, 255), (0, 200, 0), (255, 80, 0))
"""The head's x (to its left), y (down) and z (forward) axes, BGR: red, green, blue."""
LABEL_CHARS = 60
"""Longest label line; a longer reason is cut."""
WORDS = {"NE": "neutral", "HA": "happy", "SA": "sad", "SU": "surprised", "AN": "angry",
         "FE": "afraid", "DI": "disgusted"}
"""The word drawn for each expression class code (JAFFE's); other labels are drawn as they
are."""


def bgr(rgb: tuple[int, int, int]) -> tuple[int, int, int]:
    return rgb[2], rgb[1], rgb[0]


class FaceDrawing:
    """Draws the results of frames of one landmark scheme; colours worked out once."""

    def __init__(self, scheme: LandmarkScheme) -> None:
        self.scheme = scheme
        self.colours = [bgr(c) for c in point_colours(scheme)]

    def draw(self, image: np.ndarray, faces: Sequence[FaceResult], K: np.ndarray | None
             ) -> None:
        """Draw every face of ``faces`` on ``image`` (BGR, in place); ``K`` the camera
        matrix of the poses (None: no axes)."""
        scale = max(image.shape[0] / 540.0, 0.8)
        if not faces:
            label(image, ["no result for this frame"], (8, 8), face_colour(-1), scale)
        for face in faces:
            if K is not None and face.rotation is not None and face.translation_mm is not None:
                axes(image, face, K, scale)
            if len(face.landmarks):
                self.landmarks(image, face, scale)
            label(image, face_lines(face), anchor(image, face), face_colour(face.face_id), scale)

    def landmarks(self, image: np.ndarray, face: FaceResult, scale: float) -> None:
        points = np.round(face.landmarks).astype(np.int32)
        colours = self.colours if face.success else [bgr(FAILED_COLOUR)] * len(points)
        thick = max(int(round(scale)), 1)
        if len(points) == self.scheme.n_points:
            for a, b in self.scheme.edges:
                cv2.line(image, tuple(points[a]), tuple(points[b]), colours[a], thick,
                         cv2.LINE_AA)
        radius = max(int(round(2 * scale)), 2)
        for point, colour in zip(points, colours, strict=False):
            cv2.circle(image, tuple(point), radius, colour, -1, cv2.LINE_AA)
        if face.occluded is not None and face.success:
            for point in points[np.asarray(face.occluded, bool)]:
                cv2.circle(image, tuple(point), 2 * radius + 1, bgr(OCCLUDED_COLOUR), thick,
                           cv2.LINE_AA)


def axes(image: np.ndarray, face: FaceResult, K: np.ndarray, scale: float) -> None:
    """The head's axes from its origin, ``AXIS_MM`` long; thin for an unreliable pose."""
    ends = np.vstack([np.zeros(3), AXIS_MM * np.eye(3)])
    uv = project_points(ends, face.rotation, face.translation_mm, K)
    if not np.all(np.isfinite(uv)) or np.any(np.abs(uv) > 1e5):
        return
    uv = np.round(uv).astype(np.int32)
    thick = max(int(round((3 if face.pose_reliable else 1) * scale)), 1)
    for end, colour in zip(uv[1:], AXIS_COLOURS, strict=True):
        cv2.arrowedLine(image, tuple(uv[0]), tuple(end), colour, thick, cv2.LINE_AA,
                        tipLength=0.15)


def face_lines(face: FaceResult) -> list[str]:
    """The label of a face: its id, its expression and probability, or the reasons for
    what it lacks."""
    if not len(face.landmarks):
        why = face.reason or "no face"
        return [_cut(why if why.startswith("no face") else f"no face: {why}")]
    head = f"face {face.face_id}" if face.face_id >= 0 else "face"
    lines = [head + ("" if face.success else f": fit failed ({face.reason})")]
    if face.expression:
        probability = face.expression_scores.get(face.expression)
        lines.append(WORDS.get(face.expression, face.expression)
                     + (f" {probability:.0%}" if probability is not None else ""))
    elif face.expression_reason:
        lines.append(f"no expression: {face.expression_reason}")
    if face.success and face.rotation is not None and not face.pose_reliable and face.reason:
        lines.append(f"pose unreliable: {face.reason}")
    return [_cut(line) for line in lines]


def _cut(line: str) -> str:
    return line if len(line) <= LABEL_CHARS else line[:LABEL_CHARS - 3] + "..."


def anchor(image: np.ndarray, face: FaceResult) -> tuple[int, int]:
    """Where a face's label starts: above its landmarks, or the frame's top left."""
    if not len(face.landmarks):
        return 8, 8
    x, y = np.min(face.landmarks, axis=0)
    return int(np.clip(x, 0, image.shape[1] - 1)), int(np.clip(y, 0, image.shape[0] - 1))


def label(image: np.ndarray, lines: Sequence[str], at: tuple[int, int],
          colour: tuple[int, int, int], scale: float) -> None:
    """Lines of text on a dark box at ``at``, above it where there is room (in place)."""
    font, size = cv2.FONT_HERSHEY_SIMPLEX, 0.5 * scale
    thick = max(int(round(scale)), 1)
    boxes = [cv2.getTextSize(line, font, size, thick) for line in lines]
    step = max(h + base for (_, h), base in boxes) + 4
    width = max(w for (w, _), _ in boxes) + 8
    x = min(at[0], max(image.shape[1] - width, 0))
    top = at[1] - step * len(lines) - 4
    y = top if top >= 0 else at[1] + 4
    y = min(y, max(image.shape[0] - step * len(lines), 0))
    region = image[y:y + step * len(lines), x:x + width]
    region[:] = (region * 0.35).astype(np.uint8)  # a dark box the text reads on
    cv2.rectangle(image, (x, y), (x + width - 1, y + step * len(lines) - 1), bgr(colour), 1)
    for k, line in enumerate(lines):
        cv2.putText(image, line, (x + 4, y + step * (k + 1) - 6), font, size, (255, 255, 255),
                    thick, cv2.LINE_AA)
