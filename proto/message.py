"""The base of every message kind: a header and body fields declared with specs.

Each kind declares its body fields with a spec (:mod:`proto.fields`,
:mod:`proto.arrays`); constructing a message validates every field, and
``to_dict`` / ``from_dict`` convert the body to and from its msgpack map
(fields in declaration order). Arrays are read-only when decoded; arrays given
to a constructor are converted to the wire dtype, copied only when needed.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Any, ClassVar, Self

import msgpack
import numpy as np

from proto.arrays import ArraySpec
from proto.fields import Int, Spec, Str, check_keys, type_name
from proto.header import Header
from proto.keys import topic_key
from proto.limits import MAX_IMAGE_HEIGHT, MAX_IMAGE_WIDTH, MAX_SMALL_ARRAY_BYTES, ProtoError
from proto.record import Group


def spec(s: Spec) -> Any:
    """Declare a required body field validated by ``s``."""
    return field(metadata={"spec": s})


def small(dtype: str, *shape: int | None, empty: bool = False) -> Any:
    """Declare a small array field (at most ``MAX_SMALL_ARRAY_BYTES``, no NaN); with
    ``empty``, its Python default is an array with none of its free dimension (the wire
    always carries it)."""
    s = ArraySpec(dtype, shape, MAX_SMALL_ARRAY_BYTES)
    if not empty:
        return spec(s)
    size = tuple(0 if n is None else n for n in shape)
    return field(default_factory=lambda: np.zeros(size, dtype), metadata={"spec": s})


WIDTH = Int(1, MAX_IMAGE_WIDTH)
HEIGHT = Int(1, MAX_IMAGE_HEIGHT)
COUNT = Int()
NAME = Str(min_len=1)


@dataclass(frozen=True, eq=False)
class Message(Group):
    """Base of every message kind: a header and the body fields of the subclass (validated,
    specs read and ``to_dict`` as a :class:`~proto.record.Group`'s; rules across fields in
    ``_check``, overridden by kinds)."""

    KIND: ClassVar[str] = ""
    header: Header

    @classmethod
    def _prefix(cls) -> str:
        return cls.KIND

    def __post_init__(self) -> None:
        if not isinstance(self.header, Header):
            raise ProtoError(f"{self.KIND}.header: expected a Header, got {type_name(self.header)}")
        super().__post_init__()

    def key(self) -> str:
        """The Zenoh key this message is published on."""
        return topic_key(self.header.stream_id, self.KIND)

    @classmethod
    def from_dict(cls, body: Any, header: Header) -> Self:
        """Validate an unpacked body map and build the message.

        Raises
        ------
        ProtoError
            Naming the first field that does not fit.
        """
        if not isinstance(header, Header):
            raise ProtoError(f"{cls.KIND}.header: expected a Header, got {type_name(header)}")
        specs = cls.specs()
        check_keys(body, specs, cls.KIND)
        msg = object.__new__(cls)
        object.__setattr__(msg, "header", header)
        for name, s in specs.items():
            object.__setattr__(msg, name, s.decode(body[name], f"{cls.KIND}.{name}"))
        msg._check()
        return msg

    def __eq__(self, other: object) -> bool:
        # Wire equality: arrays compare by bytes, and a NaN equals itself.
        if type(other) is not type(self):
            return NotImplemented
        pack = functools.partial(msgpack.packb, use_bin_type=True)
        return self.header == other.header and pack(self.to_dict()) == pack(other.to_dict())

    __hash__ = None  # type: ignore[assignment]
