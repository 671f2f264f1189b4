"""Scalar field specifications: what an int, float, bool or string field may hold.

Each spec has ``check(value, name)``, which validates a value given in Python
and returns it normalised; ``decode(obj, name)``, which does the same for a
value unpacked from msgpack; and ``encode(value)``, which returns what to pack.
For scalars the wire value and the Python value are the same, so ``decode`` is
``check``. Array specs (:mod:`proto.arrays`) follow the same protocol.

``json_schema()`` describes a spec as a JSON Schema (draft 2020-12) fragment
of the field's JSON form (:mod:`proto.schema`): scalars as themselves, except
a NaN, which JSON lacks, as the string :data:`NAN_JSON`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from proto.limits import MAX_INT, MAX_LIST_LEN, MAX_STR_LEN, ProtoError

NAN_JSON = "NaN"
"""How a NaN float is written in the JSON form of a message (JSON has no NaN)."""
Patterns = Mapping[Callable[..., object], str]
"""Regular expression (JSON Schema ``pattern``) of each ``Str.validate`` rule."""


class Spec(Protocol):
    """The protocol of every field spec."""

    def check(self, value: Any, name: str) -> Any: ...

    def encode(self, value: Any) -> Any: ...

    def decode(self, obj: Any, name: str) -> Any: ...


def is_int(value: Any) -> bool:
    """Whether ``value`` is an integer and not a bool (``bool`` subclasses ``int``)."""
    return isinstance(value, int | np.integer) and not isinstance(value, bool)


def type_name(value: Any) -> str:
    """Short name of a value's type for error messages (never its possibly huge repr)."""
    if isinstance(value, np.ndarray):
        return f"array of dtype {value.dtype}"
    return type(value).__name__


def check_keys(obj: Any, expected: Iterable[str], name: str) -> dict[str, Any]:
    """Check that ``obj`` is a map with exactly the ``expected`` keys and return it.

    Raises
    ------
    ProtoError
        Naming the first missing or unknown key.
    """
    if not isinstance(obj, dict):
        raise ProtoError(f"{name}: expected a map, got {type_name(obj)}")
    expected = tuple(expected)
    for key in expected:
        if key not in obj:
            raise ProtoError(f"{name}: missing field {key!r}")
    for key in obj:
        if key not in expected:
            short = key[:40] if isinstance(key, str | bytes) else key
            raise ProtoError(f"{name}: unknown field {short!r}")
    return obj


@dataclass(frozen=True)
class Int:
    """An integer in ``[lo, hi]`` (int64 on the wire)."""

    lo: int = 0
    hi: int = MAX_INT

    def check(self, value: Any, name: str) -> int:
        if not is_int(value):
            raise ProtoError(f"{name}: expected an integer, got {type_name(value)}")
        if not self.lo <= value <= self.hi:
            raise ProtoError(f"{name}: {value} is outside [{self.lo}, {self.hi}]")
        return int(value)

    def encode(self, value: int) -> int:
        return value

    decode = check

    def json_schema(self) -> dict[str, Any]:
        return {"type": "integer", "minimum": self.lo, "maximum": self.hi}


@dataclass(frozen=True)
class Float:
    """A finite float in ``[lo, hi]``, or NaN where ``allow_nan`` (float64 on the wire).

    Infinities are never allowed.

    Integers are accepted on decoding (some encoders pack ``0.0`` as ``0``).
    """

    lo: float = -math.inf
    hi: float = math.inf
    allow_nan: bool = False

    def check(self, value: Any, name: str) -> float:
        if not isinstance(value, int | float | np.integer | np.floating) or isinstance(value, bool):
            raise ProtoError(f"{name}: expected a number, got {type_name(value)}")
        try:
            value = float(value)
        except OverflowError:
            raise ProtoError(f"{name}: {type_name(value)} too large for a float") from None
        if math.isnan(value):
            if not self.allow_nan:
                raise ProtoError(f"{name}: NaN is not allowed")
            return value
        if math.isinf(value):
            raise ProtoError(f"{name}: infinity is not allowed")
        if not self.lo <= value <= self.hi:
            raise ProtoError(f"{name}: {value} is outside [{self.lo}, {self.hi}]")
        return value

    def encode(self, value: float) -> float:
        return value

    decode = check

    def json_schema(self) -> dict[str, Any]:
        number: dict[str, Any] = {"type": "number"}
        if self.lo > -math.inf:
            number["minimum"] = self.lo
        if self.hi < math.inf:
            number["maximum"] = self.hi
        if not self.allow_nan:
            return number
        return {"anyOf": [number, {"const": NAN_JSON}]}


@dataclass(frozen=True)
class Bool:
    """A boolean (msgpack true/false; the integers 0 and 1 are not booleans)."""

    def check(self, value: Any, name: str) -> bool:
        if not isinstance(value, bool | np.bool_):
            raise ProtoError(f"{name}: expected a boolean, got {type_name(value)}")
        return bool(value)

    def encode(self, value: bool) -> bool:
        return value

    decode = check

    def json_schema(self) -> dict[str, Any]:
        return {"type": "boolean"}


@dataclass(frozen=True)
class Str:
    """A UTF-8 string of ``min_len`` to ``max_len`` bytes, optionally from ``choices``.

    ``validate(value, name)`` may add a rule of its own and raise ``ProtoError``.
    """

    max_len: int = MAX_STR_LEN
    min_len: int = 0
    choices: tuple[str, ...] | None = None
    validate: Callable[[str, str], object] | None = None

    def check(self, value: Any, name: str) -> str:
        if not isinstance(value, str):
            raise ProtoError(f"{name}: expected a string, got {type_name(value)}")
        try:
            size = len(value.encode("utf-8"))
        except UnicodeEncodeError:
            raise ProtoError(f"{name}: string is not valid UTF-8") from None
        if not self.min_len <= size <= self.max_len:
            raise ProtoError(
                f"{name}: string of {size} bytes is outside [{self.min_len}, {self.max_len}]"
            )
        if self.choices is not None and value not in self.choices:
            raise ProtoError(f"{name}: {value!r} is not one of {list(self.choices)}")
        if self.validate is not None:
            self.validate(value, name)
        return value

    def encode(self, value: str) -> str:
        return value

    decode = check

    def json_schema(self, patterns: Patterns | None = None) -> dict[str, Any]:
        """The fragment; ``patterns`` gives the regular expression of ``validate``.

        JSON Schema counts characters, not UTF-8 bytes: ``maxLength`` is the
        byte limit (a character is at least one byte), ``minLength`` the
        fewest characters of ``min_len`` bytes; the description states the
        byte rule.

        Raises
        ------
        ValueError
            If ``validate`` is set and ``patterns`` has no pattern for it.
        """
        out: dict[str, Any] = {"type": "string"}
        if self.choices is not None:
            out["enum"] = list(self.choices)
        else:
            if self.validate is None:
                out["description"] = f"{self.min_len} to {self.max_len} bytes of UTF-8."
            if self.min_len > 0:
                out["minLength"] = -(-self.min_len // 4)
            out["maxLength"] = self.max_len
        if self.validate is not None:
            pattern = (patterns or {}).get(self.validate)
            if pattern is None:
                rule = getattr(self.validate, "__name__", repr(self.validate))
                raise ValueError(f"no JSON Schema pattern for the string rule {rule}")
            out["pattern"] = pattern
        return out


@dataclass(frozen=True)
class StrList:
    """A list of at most ``max_items`` distinct non-empty strings; a tuple in Python."""

    max_items: int = MAX_LIST_LEN
    item: Str = Str(min_len=1)

    def check(self, value: Any, name: str) -> tuple[str, ...]:
        if not isinstance(value, list | tuple):
            raise ProtoError(f"{name}: expected a list of strings, got {type_name(value)}")
        if len(value) > self.max_items:
            raise ProtoError(f"{name}: {len(value)} items exceed {self.max_items}")
        items = tuple(self.item.check(v, f"{name}[{i}]") for i, v in enumerate(value))
        if len(set(items)) != len(items):
            raise ProtoError(f"{name}: items must be distinct")
        return items

    def encode(self, value: tuple[str, ...]) -> list[str]:
        return list(value)

    decode = check

    def json_schema(self, patterns: Patterns | None = None) -> dict[str, Any]:
        return {
            "type": "array",
            "items": self.item.json_schema(patterns),
            "maxItems": self.max_items,
            "uniqueItems": True,
        }
