"""The JSON form of messages: the decoded values, as the JSON Schemas of :mod:`proto.schema`
describe them and ``tests/proto/golden/<kind>.json`` hold them.

:func:`to_json` gives the JSON form of a message, :func:`to_payload` packs a
JSON form back to msgpack (valid or not, so that invalid examples can be fed
to :func:`proto.decode`); for a valid message ``to_payload(to_json(m)) ==
encode(m)``; :func:`dumps` writes it compactly.
"""

from __future__ import annotations

import base64
import binascii
import json
import math
from collections.abc import Iterator
from typing import Any

import msgpack
import numpy as np

from proto.arrays import ARRAY_KEYS, DTYPES
from proto.fields import NAN_JSON, Float
from proto.images import ImageSpec
from proto.messages import MESSAGE_TYPES, Message
from proto.record import GroupSpec


def _nan_to_json(value: Any) -> Any:
    if isinstance(value, list):
        return [_nan_to_json(v) for v in value]
    if isinstance(value, dict):
        return {k: _nan_to_json(v) for k, v in value.items()}
    if isinstance(value, float) and math.isnan(value):
        return NAN_JSON
    return value


def _wire_to_json(value: Any) -> Any:
    if isinstance(value, dict):
        if set(value) == set(ARRAY_KEYS) and isinstance(value["data"], bytes | memoryview):
            arr = np.frombuffer(bytes(value["data"]), DTYPES[value["dtype"]])
            data = arr.reshape(value["shape"]).tolist()
            return {"dtype": value["dtype"], "shape": list(value["shape"]), "data": data}
        return {k: _wire_to_json(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_wire_to_json(v) for v in value]
    if isinstance(value, bytes | memoryview):
        return base64.b64encode(bytes(value)).decode("ascii")
    return value


def to_json(msg: Message) -> dict[str, Any]:
    """The JSON form of a message (what its kind's schema describes)."""
    body = {
        name: _nan_to_json(_wire_to_json(spec.encode(getattr(msg, name))))
        for name, spec in msg.specs().items()
    }
    return {"header": msg.header.to_dict(msg.KIND), "body": body}


def _flatten(data: Any) -> Iterator[Any]:
    if isinstance(data, list):
        for item in data:
            yield from _flatten(item)
    else:
        yield math.nan if data == NAN_JSON else data


def _array_to_wire(value: Any) -> Any:
    """An array map with list ``data`` as bytes of its ``dtype``; anything else unchanged."""
    if not (
        isinstance(value, dict)
        and isinstance(value.get("dtype"), str)
        and isinstance(value.get("data"), list)
    ):
        return value
    code = value["dtype"]
    try:
        dtype = DTYPES.get(code) or np.dtype(code).newbyteorder("<")
        data = np.array(list(_flatten(value["data"])), dtype=dtype).tobytes()
    except (TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f"cannot pack the array of dtype {code!r}: {exc}") from None
    return {**value, "data": data}


def _field_to_wire(spec: Any, value: Any) -> Any:
    if isinstance(spec, ImageSpec) and isinstance(value, str):
        try:
            return base64.b64decode(value, validate=True)
        except binascii.Error as exc:
            raise ValueError(f"image is not base64: {exc}") from None
    if isinstance(spec, Float) and value == NAN_JSON:
        return math.nan
    if isinstance(spec, GroupSpec) and isinstance(value, dict):
        specs = spec.group.specs()
        return {k: _field_to_wire(specs[k], v) if k in specs else _array_to_wire(v)
                for k, v in value.items()}
    return _array_to_wire(value)


def from_json(obj: Any) -> Any:
    """The msgpack-ready wire map of a JSON form (inverse of :func:`to_json`).

    Works on invalid messages too: it converts what it recognises (arrays
    with list data, and by the specs of ``header.kind`` NaN floats and
    base64 images) and leaves the rest as it is.

    Raises
    ------
    ValueError
        When an array's data cannot be packed as its dtype, or an image is not
        base64.
    """
    if not isinstance(obj, dict) or not isinstance(obj.get("body"), dict):
        return obj
    header = obj.get("header")
    kind = header.get("kind") if isinstance(header, dict) else None
    cls = MESSAGE_TYPES.get(kind) if isinstance(kind, str) else None
    specs = cls.specs() if cls is not None else {}
    body = {
        name: _field_to_wire(specs[name], v) if name in specs else _array_to_wire(v)
        for name, v in obj["body"].items()
    }
    return {**obj, "body": body}


def to_payload(obj: Any) -> bytes:
    """The msgpack payload of a JSON form (valid or not)."""
    return msgpack.packb(from_json(obj), use_bin_type=True)


def dumps(obj: Any, width: int = 100) -> str:
    """JSON text indented by two spaces; a list of scalars, or a value that fits
    in ``width`` columns, on one line."""

    def dump(value: Any, level: int, column: int = 0) -> str:
        pad, end = "  " * (level + 1), "  " * level
        line = json.dumps(value, ensure_ascii=False, allow_nan=False)
        if column + len(line) <= width:
            return line
        if isinstance(value, dict) and value:
            items = []
            for k, v in value.items():
                key = f"{pad}{json.dumps(k, ensure_ascii=False)}: "
                items.append(key + dump(v, level + 1, len(key) + 1))
            return "{\n" + ",\n".join(items) + "\n" + end + "}"
        if isinstance(value, list) and any(isinstance(v, dict | list) and v for v in value):
            rows = [pad + dump(v, level + 1, len(pad) + 1) for v in value]
            return "[\n" + ",\n".join(rows) + "\n" + end + "]"
        return line

    return dump(obj, 0) + "\n"


# -- files ---------------------------------------------------------------------------------


