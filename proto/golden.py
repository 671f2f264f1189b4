"""Canonical example messages, one per kind, with fixed synthetic content.

Their encodings are committed as ``tests/proto/golden/<kind>.msgpack``, and
their decoded values, in the JSON form that ``proto/schema/<kind>.schema.json``
describes (:func:`proto.json_form.to_json`), as ``<kind>.json`` beside them; the
tests check that encoding reproduces those files byte for byte, so any change
to the contract shows up as a diff of them. After a deliberate change (and a
``SCHEMA_VERSION`` bump) regenerate them with::

    python -m proto.golden tests/proto/golden

Every number is exactly representable in its wire dtype, so the bytes do not
depend on the platform's maths library.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from proto import messages as kinds
from proto.codec import decode, encode
from proto.header import Header
from proto.json_form import dumps, to_json

CAPTURE_NS = 1_700_000_000_000_000_000
"""2023-11-14T22:13:20Z."""
GREY_JPEG_8X8 = bytes.fromhex(
    "ffd8ffe000104a46494600010100000100010000ffdb004300100b0c0e0c0a100e0d0e12111013"
    "18281a181616183123251d283a333d3c3933383740485c4e404457453738506d51575f62676867"
    "3e4d71797064785c656763ffc0000b080008000801011100ffc4001f000001050101010101010000"
    "0000000000000102030405060708090a0bffc400b5100002010303020403050504040000017d0102"
    "0300041105122131410613516107227114328191a1082342b1c11552d1f02433627282090a161718"
    "191a25262728292a3435363738393a434445464748494a535455565758595a636465666768696a73"
    "7475767778797a838485868788898a92939495969798999aa2a3a4a5a6a7a8a9aab2b3b4b5b6b7b8"
    "b9bac2c3c4c5c6c7c8c9cad2d3d4d5d6d7d8d9dae1e2e3e4e5e6e7e8e9eaf1f2f3f4f5f6f7f8f9fa"
    "ffda0008010100003f002bffd9"
)
"""An 8 x 8 mid-grey JPEG (331 bytes)."""


RUN_ID = "run-8f3a2c"


def _header(producer: str, frame_index: int = 42) -> Header:
    return Header("cam0", frame_index, CAPTURE_NS, producer, CAPTURE_NS + 5_000_000, RUN_ID,
                  frame_index * 40_000_000)  # 25 frames/s


def _fit() -> kinds.Fit:
    index = np.arange(68)
    landmarks = np.stack([100 + (index % 17) * 8.5, 150 + (index // 17) * 12.25], axis=1)
    residual = np.zeros((4, 5))
    residual[1:3, 1:4] = [[0.25, -0.5, 0.125], [1.5, -0.0625, 0.75]]
    occluded = np.zeros(68, np.uint8)
    occluded[48:60] = 1  # the outer lips, behind a hand
    return kinds.Fit(
        _header("fitter"),
        scheme="ibug68",
        landmarks=landmarks,
        similarity=np.array([1.03125, -0.015625, 12.5, -7.75]),
        image_width=640,
        image_height=480,
        failed=False,
        failure_reason="",
        confidence=0.875,
        warp_path="gpu",
        appearance=kinds.FitAppearance(
            c=np.array([0.5, -1.25, 0.125, 2.0, -0.0625]),
            texture_residual=residual,
            texture_error=0.0123,
            iterations=0,
            converged=True,
            occluded=occluded,
        ),
    )


def _head_pose() -> kinds.HeadPose:
    return kinds.HeadPose(
        _header("pose"),
        rotation=np.array([[0.8, 0.0, 0.6], [0.0, 1.0, 0.0], [-0.6, 0.0, 0.8]]),
        translation_mm=np.array([12.5, -30.0, 650.0]),
        roll_deg=0.0,
        pitch_deg=0.0,
        yaw_deg=36.87,
        intrinsics=np.array([[800.0, 0.0, 320.0], [0.0, 800.0, 240.0], [0.0, 0.0, 1.0]]),
        image_width=640,
        image_height=480,
        intrinsics_source="assumed:fov43.6",
        iterations=4,
        reliable=True,
        reason="",
        angle_sd_deg=0.75,
        covered=np.array([[300.5, 400.25], [310.0, 402.5], [320.75, 401.0]]),  # the lips
    )


def _status() -> kinds.Status:
    return kinds.Status(
        _header("fitter", frame_index=999),
        service="fitter",
        state="running",
        frames_in=1000,
        frames_out=990,
        dropped=8,
        rejected=2,
        lost=1,
        ignored=3,
        failed=1,
        latency_p50_ms=4.5,
        latency_p99_ms=11.25,
        restarts=0,
        message="",
    )


def golden_messages() -> dict[str, kinds.Message]:
    """One canonical message of each kind, keyed by kind."""
    messages: list[kinds.Message] = [
        kinds.Frame.from_array(_header("source"), np.arange(72, dtype=np.uint8).reshape(4, 6, 3)),
        kinds.FaceBoxes(
            _header("detector"),
            image_width=640,
            image_height=480,
            boxes=np.array([[200.5, 120.25, 180.0, 180.0], [10.0, 20.0, 30.0, 40.0]]),
            scores=np.array([0.875, 0.25]),
        ),
        _fit(),
        _head_pose(),
        kinds.Expression(
            _header("expression"),
            label="happy",
            class_names=("neutral", "happy", "sad", "surprise", "anger", "disgust", "fear"),
            scores=np.array([4, 45, 3, 5, 2, 3, 2]) / 64,
            smoothed=True,
            reason="",
        ),
        kinds.Overlay.from_jpeg(_header("ar"), GREY_JPEG_8X8, width=8, height=8),
        _status(),
        kinds.EndOfStream(_header("source"), total_frames=43, reason="end_of_file"),
    ]
    return {m.KIND: m for m in messages}


def golden_json(payload: bytes) -> str:
    """The JSON text of a golden payload's decoded message (``<kind>.json``)."""
    return dumps(to_json(decode(payload)))


def write_golden(directory: Path) -> list[tuple[Path, Path]]:
    """Write ``<kind>.msgpack`` and ``<kind>.json`` for every golden message into ``directory``.

    Returns the pair of paths of each kind.
    """
    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    for kind, msg in golden_messages().items():
        payload = encode(msg)
        path = directory / f"{kind}.msgpack"
        path.write_bytes(payload)
        json_path = directory / f"{kind}.json"
        json_path.write_text(golden_json(payload), encoding="utf-8")
        paths.append((path, json_path))
    return paths


def main(argv: list[str] | None = None) -> int:
    """``python -m proto.golden DIR``: regenerate the golden files (one line per kind)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("directory", type=Path, help="e.g. tests/proto/golden")
    for path, json_path in write_golden(parser.parse_args(argv).directory):
        print(path, json_path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
