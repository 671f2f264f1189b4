"""The array codec: numpy arrays as ``{"dtype", "shape", "data"}`` msgpack maps.

msgpack has no array type (and ``packb`` rejects numpy), so an array travels
as a map ``{"dtype": "f4", "shape": [68, 2], "data": <bin>}``: ``data`` holds
the elements in C (row-major) order, little-endian, and its length is exactly
``prod(shape) * itemsize``. Only the dtypes in :data:`DTYPES` exist on the wire.

In the JSON form of a message (:mod:`proto.schema`) ``data`` is the elements
as nested lists instead, one level per dimension (``numpy.ndarray.tolist``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from proto.fields import NAN_JSON, check_keys, is_int, type_name
from proto.limits import MAX_DIM, ProtoError

DTYPES: dict[str, np.dtype] = {
    "u1": np.dtype("u1"),
    "f4": np.dtype("<f4"),
    "f8": np.dtype("<f8"),
}
"""The allow-list of wire dtypes: code -> little-endian numpy dtype."""

ARRAY_KEYS = ("dtype", "shape", "data")


def _shape_text(shape: tuple[int | None, ...]) -> str:
    return "(" + ", ".join("*" if d is None else str(d) for d in shape) + ")"


@dataclass(frozen=True)
class ArraySpec:
    """What one array field may hold.

    Parameters
    ----------
    dtype : str
        Wire dtype code, a key of :data:`DTYPES`.
    shape : tuple of int or None
        Expected shape; ``None`` is any length from 0 to :data:`MAX_DIM`.
    max_bytes : int
        Largest ``data`` length.
    allow_nan : bool
        Whether NaN elements are allowed (infinities never are).
    """

    dtype: str
    shape: tuple[int | None, ...]
    max_bytes: int
    allow_nan: bool = False

    def check(self, value: Any, name: str) -> np.ndarray:
        """Validate an array given in Python and return it as a contiguous wire-dtype array.

        Floating-point fields accept any real array-like and cast it; ``u1``
        fields take only ``uint8`` arrays (a silent cast would wrap values).
        """
        wire = DTYPES[self.dtype]
        if wire.kind == "u":
            if not (isinstance(value, np.ndarray) and value.dtype == wire):
                raise ProtoError(f"{name}: expected a uint8 numpy array, got {type_name(value)}")
        else:
            try:
                value = np.asarray(value)
            except (TypeError, ValueError) as exc:
                raise ProtoError(f"{name}: not an array ({exc})") from None
            if value.dtype.kind not in "iuf":
                raise ProtoError(f"{name}: expected real numbers, got dtype {value.dtype}")
        arr = np.ascontiguousarray(value, dtype=wire)
        self._check_shape(arr.shape, name)
        self._check_bytes(arr.nbytes, name)
        self._check_values(arr, name)
        return arr

    def encode(self, arr: np.ndarray) -> dict[str, Any]:
        """Return the wire map of an array already passed through :meth:`check`."""
        return {
            "dtype": self.dtype,
            "shape": list(arr.shape),
            "data": memoryview(arr.reshape(-1).view(np.uint8)),
        }

    def decode(self, obj: Any, name: str) -> np.ndarray:
        """Validate a decoded wire map and return a read-only array viewing its data.

        Raises
        ------
        ProtoError
            On a non-map, missing or extra keys, a dtype outside the allow-list
            or not the field's, a malformed or wrong shape, too many bytes, a
            ``data`` length that does not match the shape, or NaN/inf elements
            where they are not allowed.
        """
        if not isinstance(obj, dict):
            raise ProtoError(f"{name}: expected an array map, got {type_name(obj)}")
        check_keys(obj, ARRAY_KEYS, name)
        code, shape, data = obj["dtype"], obj["shape"], obj["data"]
        if not isinstance(code, str):
            raise ProtoError(f"{name}: dtype must be a string, got {type_name(code)}")
        if code not in DTYPES:
            raise ProtoError(f"{name}: dtype {code!r} is not in the allow-list {sorted(DTYPES)}")
        if code != self.dtype:
            raise ProtoError(f"{name}: dtype must be {self.dtype!r}, got {code!r}")
        if not isinstance(shape, list) or len(shape) != len(self.shape):
            got = f"list of {len(shape)}" if isinstance(shape, list) else type_name(shape)
            raise ProtoError(f"{name}: shape must be a list of {len(self.shape)} ints, got {got}")
        if not all(is_int(d) for d in shape):
            raise ProtoError(
                f"{name}: shape must hold integers, got {[type_name(d) for d in shape]}"
            )
        shape_t = tuple(shape)
        self._check_shape(shape_t, name)
        nbytes = math.prod(shape_t) * DTYPES[code].itemsize
        self._check_bytes(nbytes, name)
        if isinstance(data, bytearray) or (isinstance(data, memoryview) and not data.readonly):
            data = bytes(data)  # from to_dict() rather than msgpack: the array must not change
        if isinstance(data, memoryview):  # a read-only view of a payload (codec): kept, not copied
            data = data.cast("B") if data.format != "B" else data
        if not isinstance(data, bytes | memoryview):
            raise ProtoError(f"{name}: data must be binary, got {type_name(data)}")
        if len(data) != nbytes:
            raise ProtoError(
                f"{name}: data has {len(data)} bytes but shape {list(shape_t)} of {code} "
                f"needs {nbytes}"
            )
        arr = np.frombuffer(data, dtype=DTYPES[code]).reshape(shape_t)
        self._check_values(arr, name)
        return arr

    def json_schema(self) -> dict[str, Any]:
        """A JSON Schema fragment of the array's JSON form, ``data`` as nested lists.

        Fixed dimensions are exact lengths of ``shape`` and of the lists;
        that the lists' lengths equal a free dimension's ``shape`` entry, and
        the byte limit, are stated in the description only.
        """
        if DTYPES[self.dtype].kind == "u":
            info = np.iinfo(DTYPES[self.dtype])
            item: dict[str, Any] = {
                "type": "integer",
                "minimum": int(info.min),
                "maximum": int(info.max),
            }
        else:
            item = {"type": "number"}
            if self.allow_nan:
                item = {"anyOf": [item, {"const": NAN_JSON}]}
        data = item
        for want in reversed(self.shape):
            lengths = (
                {"maxItems": MAX_DIM} if want is None else {"minItems": want, "maxItems": want}
            )
            data = {"type": "array", "items": data, **lengths}
        dims = [
            {"type": "integer", "minimum": 0, "maximum": MAX_DIM}
            if want is None
            else {"const": want}
            for want in self.shape
        ]
        shape = _shape_text(self.shape)
        shape = shape[:-1] + ",)" if len(self.shape) == 1 else shape
        free = f" (* a free dimension, 0 to {MAX_DIM})" if None in self.shape else ""
        if DTYPES[self.dtype].kind != "f":
            values = ""
        elif self.allow_nan:
            values = '; NaN elements allowed (as the string "NaN"), no infinity'
        else:
            values = "; no NaN, no infinity"
        return {
            "type": "object",
            "description": (
                f"A {shape} {self.dtype} ({DTYPES[self.dtype].name}) array{free}: data holds "
                "its elements as nested lists in row-major order, one list level per "
                "dimension, each list as long as its entry of shape (on the wire: little-endian "
                f"bytes, at most {self.max_bytes}){values}."
            ),
            "properties": {
                "dtype": {"const": self.dtype},
                "shape": {
                    "type": "array",
                    "prefixItems": dims,
                    "minItems": len(dims),
                    "maxItems": len(dims),
                },
                "data": data,
            },
            "required": list(ARRAY_KEYS),
            "additionalProperties": False,
        }

    def _check_shape(self, shape: tuple[int, ...], name: str) -> None:
        ok = len(shape) == len(self.shape) and all(
            (0 <= d <= MAX_DIM) if want is None else d == want
            for d, want in zip(shape, self.shape, strict=True)
        )
        if not ok:
            raise ProtoError(
                f"{name}: shape {list(shape)} does not match {_shape_text(self.shape)} "
                f"(free dimensions at most {MAX_DIM})"
            )

    def _check_bytes(self, nbytes: int, name: str) -> None:
        if nbytes > self.max_bytes:
            raise ProtoError(f"{name}: {nbytes} bytes exceed the limit of {self.max_bytes}")

    def _check_values(self, arr: np.ndarray, name: str) -> None:
        if arr.dtype.kind != "f":
            return
        bad = ~np.isfinite(arr)
        if self.allow_nan:
            bad &= ~np.isnan(arr)
        if bad.any():
            what = "infinite" if self.allow_nan else "NaN or infinite"
            raise ProtoError(f"{name}: {int(bad.sum())} {what} element(s)")
