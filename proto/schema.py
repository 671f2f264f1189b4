"""The contract as JSON Schema (draft 2020-12), generated from the field specs.

Each kind's schema describes the **JSON form** of its messages: the decoded
values, as in ``tests/proto/golden/<kind>.json``, rather than the msgpack
bytes. The JSON form is the wire map with three changes, since JSON has no
binary and no NaN:

- an array's ``data`` is its elements as nested lists, one level per
  dimension (``numpy.ndarray.tolist``), instead of little-endian bytes;
- a JPEG image (a msgpack bin) is its bytes in base64 (RFC 4648, padded);
- a NaN float is the string ``"NaN"``; infinities never occur.

The JSON form itself is :mod:`proto.json_form`. The schemas come from the
specs of :mod:`proto.fields` and :mod:`proto.arrays` (their ``json_schema``
methods), the field descriptions
from the docstrings of the message classes, and the rules that tie fields
together from :data:`proto.schema_rules.RULES`; what JSON Schema cannot express is stated in the
descriptions. The generated files are committed under ``proto/schema/``;
regenerate them with::

    python -m proto.schema proto/schema
"""

from __future__ import annotations

import argparse
import base64
import inspect
import math
import re
from pathlib import Path
from typing import Any

from proto.arrays import ArraySpec
from proto.codec import payload_limit
from proto.fields import Str, StrList
from proto.header import _SPECS as HEADER_SPECS
from proto.header import AUTH_HEX, SCHEMA_VERSION, WIRE_KEYS, Header, check_auth, check_run_id
from proto.images import JPEG_MAGIC, ImageSpec
from proto.json_form import dumps
from proto.keys import NAME_MAX_LEN, check_name
from proto.messages import MESSAGE_TYPES, Message
from proto.record import GroupSpec
from proto.schema_rules import _HEADER_EXTRA, CONVENTIONS, JSON_FORM, RULES

DRAFT = "https://json-schema.org/draft/2020-12/schema"
SCHEMA_DIR = Path(__file__).parent / "schema"
"""Where the generated schemas are committed."""

_NAME_CORE = f"[A-Za-z0-9_][A-Za-z0-9_.-]{{0,{NAME_MAX_LEN - 1}}}"
NAME_PATTERN = f"^{_NAME_CORE}$"
"""A stream id or service name (:func:`proto.keys.check_name`)."""
RUN_ID_PATTERN = f"^(|{_NAME_CORE})$"
"""A run id: empty or a name (:func:`proto.header.check_run_id`)."""
PATTERNS = {check_name: NAME_PATTERN, check_run_id: RUN_ID_PATTERN,
            check_auth: f"^([0-9a-f]{{{AUTH_HEX}}})?$"}
"""The ``pattern`` of each ``Str.validate`` rule of the contract."""
JPEG_BASE64_PATTERN = (
    "^" + base64.b64encode(JPEG_MAGIC).decode() + "([A-Za-z0-9+/]{4})*"
    "([A-Za-z0-9+/]{2}==|[A-Za-z0-9+/]{3}=)?$"
)
"""Padded base64 of bytes that start with ``FF D8 FF`` (which encode to ``/9j/``)."""

# -- descriptions --------------------------------------------------------------------------


def _plain(text: str) -> str:
    """Docstring text without reST roles and double backquotes."""
    return re.sub(r":\w+:`~?([^`]+)`", r"`\1`", text).replace("``", "`")


def parameter_docs(cls: type) -> dict[str, str]:
    """Field name -> description, from the ``Parameters`` sections of ``cls`` and its bases."""
    docs: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        lines = inspect.cleandoc(klass.__dict__.get("__doc__") or "").splitlines()
        if "Parameters" not in lines:
            continue
        names: list[str] = []
        for line in lines[lines.index("Parameters") + 2 :]:
            if not line.strip():
                continue
            if not line.startswith(" "):
                if " : " not in line:
                    break  # the next section
                names = [n.strip() for n in line.split(" : ")[0].split(",")]
                for name in names:
                    docs[name] = ""
            else:
                for name in names:
                    docs[name] = (docs[name] + " " + line.strip()).strip()
    return {name: _plain(text) for name, text in docs.items()}


def summary(cls: type) -> str:
    """The first line of a class's docstring, without a "(see ...)" remark."""
    first = inspect.cleandoc(cls.__doc__ or "").splitlines()[0]
    return _plain(re.sub(r"\s*\(see [^)]*\)", "", first))


# -- schema fragments ----------------------------------------------------------------------


def _jpeg_schema(spec: ImageSpec) -> dict[str, Any]:
    return {
        "type": "string",
        "description": "JPEG file bytes in base64; the file starts with FF D8 FF.",
        "contentEncoding": "base64",
        "contentMediaType": "image/jpeg",
        "pattern": JPEG_BASE64_PATTERN,
        "maxLength": 4 * math.ceil(spec.max_bytes / 3),
    }


def fragment(spec: Any) -> dict[str, Any]:
    """The JSON Schema fragment of one field spec.

    Raises
    ------
    TypeError
        For a spec of no known kind.
    """
    if isinstance(spec, ImageSpec):
        return {
            "anyOf": [
                ArraySpec("u1", (None, None, 3), spec.max_bytes).json_schema(),
                ArraySpec("u1", (None, None), spec.max_bytes).json_schema(),
                _jpeg_schema(spec),
            ]
        }
    if isinstance(spec, Str | StrList):
        return spec.json_schema(PATTERNS)
    if isinstance(spec, GroupSpec):
        return group_schema(spec)
    if hasattr(spec, "json_schema"):
        return spec.json_schema()
    raise TypeError(f"no JSON Schema for the spec {spec!r}")


def group_schema(spec: GroupSpec) -> dict[str, Any]:
    """The fragment of a field holding a group of fields: an object of exactly them (each
    described by the group's docstring), or null where the field may be nil."""
    docs = parameter_docs(spec.group)
    props = {name: _described(fragment(s), docs[name]) for name, s in spec.group.specs().items()}
    group = {"type": "object", "description": summary(spec.group), "properties": props,
             "required": list(props), "additionalProperties": False}
    if not spec.nullable:
        return group
    return {"anyOf": [group, {"type": "null"}]}


def _described(frag: dict[str, Any], *texts: str) -> dict[str, Any]:
    """``frag`` with ``texts`` (and its own description) as its description, first."""
    text = " ".join(t for t in (*texts, frag.get("description", "")) if t)
    return {"description": text, **{k: v for k, v in frag.items() if k != "description"}}


def header_schema(kind: str | None = None) -> dict[str, Any]:
    """The header's schema; ``kind`` fixes ``header.kind`` (default: any kind)."""
    docs = parameter_docs(Header) | _HEADER_EXTRA
    kinds = {"enum": list(MESSAGE_TYPES)} if kind is None else {"const": kind}
    props: dict[str, Any] = {
        "schema_version": {"type": "integer", "const": SCHEMA_VERSION},
        "kind": {"type": "string", **kinds},
    } | {name: fragment(spec) for name, spec in HEADER_SPECS.items()}
    return {
        "type": "object",
        "description": "Where a message comes from and which frame it is about.",
        "properties": {name: _described(props[name], docs[name]) for name in WIRE_KEYS},
        "required": list(WIRE_KEYS),
        "additionalProperties": False,
    }


def body_schema(cls: type[Message]) -> dict[str, Any]:
    """The schema of a kind's body, with its cross-field rules."""
    docs = parameter_docs(cls)
    props = {
        name: _described(fragment(spec), docs[name], CONVENTIONS.get((cls.KIND, name), ""))
        for name, spec in cls.specs().items()
    }
    out: dict[str, Any] = {"type": "object"}
    rules = RULES.get(cls.KIND, [])
    if rules:
        texts = [
            f"({i}) {text}" + ("" if frag is not None else " [description only]")
            for i, (text, frag) in enumerate(rules, start=1)
        ]
        out["description"] = (
            "Rules across fields: " + "; ".join(texts) + ". A rule marked [description only] "
            "is beyond JSON Schema: a decoder checks it."
        )
    out |= {"properties": props, "required": list(props), "additionalProperties": False}
    checks = [frag for _, frag in rules if frag is not None]
    if checks:
        out["allOf"] = checks
    return out


def message_schema(kind: str) -> dict[str, Any]:
    """The schema of a whole message of ``kind``, header and body."""
    cls = MESSAGE_TYPES[kind]
    return {
        "$schema": DRAFT,
        "$id": f"urn:aamtrack:proto:{SCHEMA_VERSION}:{kind}",
        "title": f"aamtrack {kind} message, schema version {SCHEMA_VERSION}",
        "description": (
            f"{summary(cls)} A msgpack map of a header and a body; the payload is at most "
            f"{payload_limit(kind)} bytes. {JSON_FORM}"
        ),
        "type": "object",
        "properties": {"header": {"$ref": "#/$defs/header"}, "body": {"$ref": "#/$defs/body"}},
        "required": ["header", "body"],
        "additionalProperties": False,
        "$defs": {"header": header_schema(kind), "body": body_schema(cls)},
    }


def schemas() -> dict[str, dict[str, Any]]:
    """File stem -> schema: ``header`` and every kind."""
    header = {
        "$schema": DRAFT,
        "$id": f"urn:aamtrack:proto:{SCHEMA_VERSION}:header",
        "title": f"aamtrack message header, schema version {SCHEMA_VERSION}",
    } | header_schema()
    return {"header": header} | {kind: message_schema(kind) for kind in MESSAGE_TYPES}


def write_schemas(directory: Path) -> list[Path]:
    """Write ``<kind>.schema.json`` and ``header.schema.json`` into ``directory``."""
    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    for stem, schema in schemas().items():
        path = directory / f"{stem}.schema.json"
        path.write_text(dumps(schema), encoding="utf-8")
        paths.append(path)
    return paths


def main(argv: list[str] | None = None) -> int:
    """``python -m proto.schema DIR``: write the JSON Schemas."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("directory", type=Path, help="e.g. proto/schema")
    for path in write_schemas(parser.parse_args(argv).directory):
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
