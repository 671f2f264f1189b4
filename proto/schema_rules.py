"""What the JSON Schemas of the contract say beyond the field specs: the JSON form's note,
the rules that tie fields together, and the conventions of pixels and poses.

:mod:`proto.schema` puts them into the schemas it generates.
"""

from __future__ import annotations

from typing import Any

from proto.header import SCHEMA_VERSION
from proto.limits import MAX_IMAGE_PIXELS

JSON_FORM = (
    "This schema describes the JSON form of the msgpack message (the decoded values): an "
    "array's data as nested lists instead of little-endian bytes, a JPEG image (msgpack bin) "
    'as base64, a NaN as the string "NaN"; there is no infinity. JSON Schema counts a '
    "string's characters, the contract its UTF-8 bytes, and treats 1.0 as an integer where "
    "msgpack does not; rules it cannot express are in the descriptions."
)

RULES: dict[str, list[tuple[str, dict[str, Any] | None]]] = {
    "frame": [
        (f"width * height <= {MAX_IMAGE_PIXELS}", None),
        (
            'encoding "raw": image is an array; "jpeg": image is a base64 JPEG string',
            {
                "if": {"properties": {"encoding": {"const": "raw"}}},
                "then": {"properties": {"image": {"type": "object"}}},
                "else": {"properties": {"image": {"type": "string"}}},
            },
        ),
        ("a raw image's shape starts with [height, width]", None),
    ],
    "boxes": [
        ("scores has one element per row of boxes", None),
        (
            "no box has a negative width or height (columns 2 and 3)",
            {
                "properties": {
                    "boxes": {
                        "properties": {
                            "data": {
                                "items": {
                                    "prefixItems": [True, True, {"minimum": 0}, {"minimum": 0}]
                                }
                            }
                        }
                    }
                }
            },
        ),
    ],
    "fit": [
        (
            "similarity has 4 elements or none",
            {
                "properties": {
                    "similarity": {
                        "properties": {
                            "shape": {"prefixItems": [{"enum": [0, 4]}]},
                            "data": {"anyOf": [{"maxItems": 0}, {"minItems": 4, "maxItems": 4}]},
                        }
                    }
                }
            },
        ),
        (
            "failure_reason is non-empty exactly when failed is true",
            {
                "if": {"properties": {"failed": {"const": True}}},
                "then": {"properties": {"failure_reason": {"minLength": 1}}},
                "else": {"properties": {"failure_reason": {"maxLength": 0}}},
            },
        ),
        (
            'an appearance (not null) needs landmarks and a warp_path of "gpu" or "cpu"',
            {
                "if": {"properties": {"appearance": {"type": "object"}}},
                "then": {"properties": {"warp_path": {"enum": ["gpu", "cpu"]}}},
            },
        ),
        ("appearance.occluded has one flag (0 or 1) per landmark, or none", None),
        (
            "face_id is -1 only for a failed fit (a good fit has an id >= 0)",
            {
                "if": {"properties": {"failed": {"const": False}}},
                "then": {"properties": {"face_id": {"minimum": 0}}},
            },
        ),
    ],
    "pose": [
        (
            "intrinsics: fx (row 0, column 0) > 0, fy (row 1, column 1) > 0, last row [0, 0, 1]",
            {
                "properties": {
                    "intrinsics": {
                        "properties": {
                            "data": {
                                "prefixItems": [
                                    {"prefixItems": [{"exclusiveMinimum": 0}]},
                                    {"prefixItems": [True, {"exclusiveMinimum": 0}]},
                                    {"const": [0, 0, 1]},
                                ]
                            }
                        }
                    }
                }
            },
        ),
        (
            "reason is non-empty exactly when reliable is false",
            {
                "if": {"properties": {"reliable": {"const": False}}},
                "then": {"properties": {"reason": {"minLength": 1}}},
                "else": {"properties": {"reason": {"maxLength": 0}}},
            },
        ),
    ],
    "expression": [
        (
            "reason is non-empty exactly when label is empty",
            {
                "if": {"properties": {"label": {"maxLength": 0}}},
                "then": {"properties": {"reason": {"minLength": 1}}},
                "else": {"properties": {"reason": {"maxLength": 0}}},
            },
        ),
        ("a non-empty label is one of class_names", None),
        ("scores has one element per class name with a label and none without; its "
         "probabilities sum to 1", None),
    ],
}
"""Rules that tie fields together, per kind: text, and the JSON Schema of the rule
where JSON Schema can express it (``None``: the description states it, a decoder
checks it)."""
RULES["overlay"] = RULES["frame"]

_PIXELS = (
    "Pixel coordinates as OpenCV's: x to the right, y down, pixel centres at integers (the "
    "centre of the top-left pixel is (0, 0); the image spans [-0.5, width - 0.5] x "
    "[-0.5, height - 0.5])."
)
_ORIGIN = (
    "The origin of the head model is the centroid of the 68 points of the OpenFace mean iBUG-68 "
    "head (models3d/openface_mean68/mean68_mm.csv), whichever of its points the pose was "
    "estimated from. In the head's own frame (upright, facing the camera) it lies on the "
    "face's midline, 38.5 mm below the midpoint of the eyes (the mean of landmarks 36-47), "
    "8.4 mm below the nose tip (landmark 30, 0-based) and 37 mm behind it, at about the depth "
    "of the eyes (1.5 mm in front of their mean)."
)
_IMAGE = (
    'With encoding "raw": a (height, width, 3) u1 array in BGR order (OpenCV\'s), or a (height, '
    'width) u1 grey array; "jpeg": a JPEG file of width x height pixels.'
)
CONVENTIONS: dict[tuple[str, str], str] = {
    ("frame", "image"): _IMAGE,
    ("overlay", "image"): _IMAGE,
    ("boxes", "boxes"): _PIXELS,
    ("fit", "landmarks"): _PIXELS,
    ("pose", "rotation"): (
        "A point X of the head model (mm) is at X_cam = R X + T in camera coordinates. Camera "
        "axes are OpenCV's: +x right, +y down, +z forward (away from the camera along the "
        "optical axis); the model has the same axes, and R = I is a face looking straight "
        "into the camera. R = Rz(roll) Ry(yaw) Rx(pitch) (thesis eq 14.1): the pitch rotation "
        "is applied first, then yaw, then roll, each about the fixed camera axes. R is a "
        "rotation matrix; a decoder does not check it."
    ),
    ("pose", "translation_mm"): "T of X_cam = R X + T. " + _ORIGIN,
    ("pose", "roll_deg"): (
        "Roll: the rotation about the z axis (the optical axis), applied last; positive turns "
        "the face clockwise in the image. From R (eq 14.3) the producer gives (-180, 180]."
    ),
    ("pose", "pitch_deg"): (
        "Pitch: the rotation about the x axis (pointing right), applied first; positive moves "
        "the nose down. From R (eq 14.3) the producer gives (-180, 180]."
    ),
    ("pose", "yaw_deg"): (
        "Yaw: the rotation about the y axis (pointing down), applied second; positive moves "
        "the nose towards image left (the subject turns to their right). From R (eq 14.3) the "
        "producer gives [-90, 90]."
    ),
}
"""Conventions added to a field's description, by (kind, field)."""

_HEADER_EXTRA = {
    "schema_version": f"Version of the contract: {SCHEMA_VERSION}.",
    "kind": "The message kind.",
}


