"""Groups of fields that travel together: a map inside a message body, or nil.

A :class:`Group` is a frozen dataclass whose fields are declared with specs,
as a message's body fields are (:func:`proto.message.spec`); constructing one
validates every field. :class:`GroupSpec` is the spec of a body field holding
a group: on the wire a msgpack map of exactly the group's fields, or nil where
the group is ``nullable`` (a fit without an appearance has ``appearance: nil``).
The field's key is always there: the contract still has no optional keys.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, fields
from typing import Any, ClassVar

import msgpack

from proto.fields import Spec, check_keys, type_name
from proto.limits import ProtoError


@dataclass(frozen=True, eq=False)
class Group:
    """Base of a group of fields declared with specs (and of every message's body,
    :class:`proto.message.Message`)."""

    NAME: ClassVar[str] = ""
    """How errors name the group (``fit.appearance``)."""

    @classmethod
    def _prefix(cls) -> str:
        return cls.NAME

    def __post_init__(self) -> None:
        for name, s in self.specs().items():
            object.__setattr__(self, name, s.check(getattr(self, name), f"{self._prefix()}.{name}"))
        self._check()

    def _check(self) -> None:
        """Rules that tie the group's fields together; raise ``ProtoError``."""

    @classmethod
    @functools.cache
    def specs(cls) -> dict[str, Spec]:
        """Field name -> spec, in wire order."""
        return {f.name: f.metadata["spec"] for f in fields(cls) if "spec" in f.metadata}

    def to_dict(self) -> dict[str, Any]:
        """The group as a msgpack-ready map."""
        return {name: s.encode(getattr(self, name)) for name, s in self.specs().items()}

    def __eq__(self, other: object) -> bool:
        # Wire equality, as messages compare.
        if type(other) is not type(self):
            return NotImplemented
        pack = functools.partial(msgpack.packb, use_bin_type=True)
        return pack(self.to_dict()) == pack(other.to_dict())  # type: ignore[attr-defined]

    __hash__ = None  # type: ignore[assignment]


@dataclass(frozen=True)
class GroupSpec:
    """A body field holding a :class:`Group` (or nothing, where ``nullable``).

    Parameters
    ----------
    group : type of Group
    nullable : bool
        Whether the field may be nil (None in Python).
    """

    group: type[Group]
    nullable: bool = True

    def check(self, value: Any, name: str) -> Group | None:
        if value is None:
            if not self.nullable:
                raise ProtoError(f"{name}: must not be nil")
            return None
        if not isinstance(value, self.group):
            raise ProtoError(f"{name}: expected {self.group.__name__} or None, "
                             f"got {type_name(value)}")
        return value

    def encode(self, value: Group | None) -> dict[str, Any] | None:
        return None if value is None else value.to_dict()

    def decode(self, obj: Any, name: str) -> Group | None:
        if obj is None:
            return self.check(None, name)
        specs = self.group.specs()
        check_keys(obj, specs, name)
        group = object.__new__(self.group)
        for key, s in specs.items():
            object.__setattr__(group, key, s.decode(obj[key], f"{name}.{key}"))
        group._check()
        return group
