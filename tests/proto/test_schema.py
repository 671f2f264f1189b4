"""The JSON Schemas, the golden JSON values and the invalid examples agree with the decoder."""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from proto import ProtoError, decode, encode
from proto.golden import golden_json, golden_messages
from proto.header import Header
from proto.json_form import to_json, to_payload
from proto.keys import check_name
from proto.message import Message
from proto.messages import MESSAGE_TYPES, FaceBoxes, Fit, Frame, Status
from proto.schema import NAME_PATTERN, RUN_ID_PATTERN, SCHEMA_DIR, fragment, main, schemas
from proto.schema_rules import RULES

GOLDEN_DIR = Path(__file__).parent / "golden"
INVALID = Path(__file__).parent / "invalid.json"
CASES: list[dict[str, Any]] = json.loads(INVALID.read_text(encoding="utf-8"))["cases"]


def _validator(schema: dict[str, Any]) -> Any:
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def _committed_schema(stem: str) -> dict[str, Any]:
    return json.loads((SCHEMA_DIR / f"{stem}.schema.json").read_text(encoding="utf-8"))


def _golden_json(kind: str) -> dict[str, Any]:
    return json.loads((GOLDEN_DIR / f"{kind}.json").read_text(encoding="utf-8"))


def _pointer(path: str) -> list[str]:
    return [p.replace("~1", "/").replace("~0", "~") for p in path.split("/")[1:]]


def apply_patch(doc: Any, patch: list[dict[str, Any]]) -> Any:
    """A JSON Patch (RFC 6902) of ``add``, ``replace`` and ``remove`` operations."""
    doc = copy.deepcopy(doc)
    for op in patch:
        *parents, last = _pointer(op["path"])
        target = doc
        for part in parents:
            target = target[int(part)] if isinstance(target, list) else target[part]
        if isinstance(target, list):
            index = len(target) if last == "-" else int(last)
            if op["op"] == "add":
                target.insert(index, op["value"])
                continue
            assert 0 <= index < len(target), op
            if op["op"] == "remove":
                del target[index]
            else:
                target[index] = op["value"]
        else:
            assert op["op"] == "add" or last in target, op
            if op["op"] == "remove":
                del target[last]
            else:
                target[last] = op["value"]
    return doc


# -- the schema files ----------------------------------------------------------------------


def test_committed_schemas_are_what_the_specs_generate(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main([str(tmp_path)]) == 0
    written = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    committed = {p.name: p.read_bytes() for p in SCHEMA_DIR.iterdir()}
    assert sorted(written) == sorted(committed), "stale or missing files in proto/schema/"
    for name, text in written.items():
        assert committed[name] == text, f"proto/schema/{name} drifted: python -m proto.schema"
    assert len(capsys.readouterr().out.splitlines()) == len(MESSAGE_TYPES) + 1


@pytest.mark.parametrize("stem", ["header", *MESSAGE_TYPES])
def test_each_schema_is_valid_draft_2020_12(stem: str) -> None:
    schema = _committed_schema(stem)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    _validator(schema)


def _descriptions(props: dict[str, Any]) -> dict[str, str]:
    return {name: prop.get("description", "") for name, prop in props.items()}


@pytest.mark.parametrize("kind", list(MESSAGE_TYPES))
def test_every_field_is_described_and_required(kind: str) -> None:
    defs = schemas()[kind]["$defs"]
    for part in ("header", "body"):
        props = defs[part]["properties"]
        assert all(_descriptions(props).values()), f"{kind}.{part}: undescribed fields"
        assert defs[part]["required"] == list(props)
        assert defs[part]["additionalProperties"] is False
    assert list(defs["body"]["properties"]) == list(MESSAGE_TYPES[kind].specs())


def test_every_cross_field_check_is_listed_in_the_rules() -> None:
    for kind, cls in MESSAGE_TYPES.items():
        if cls._check is not Message._check:
            assert RULES.get(kind), f"{kind} checks rules across fields: list them in RULES"
    assert set(RULES) <= set(MESSAGE_TYPES)


def test_pose_schema_states_the_conventions() -> None:
    props = schemas()["pose"]["$defs"]["body"]["properties"]
    assert "X_cam = R X + T" in props["rotation"]["description"]
    assert "Rz(roll) Ry(yaw) Rx(pitch)" in props["rotation"]["description"]
    assert "+y down" in props["rotation"]["description"]
    assert "centroid of the 68 points" in props["translation_mm"]["description"]
    for angle in ("roll", "pitch", "yaw"):
        assert "positive" in props[f"{angle}_deg"]["description"]


NAMES = ["cam0", "a", "_", "A.b-c_9", "x" * 64, "0lead"]
NOT_NAMES = ["", ".a", "-a", "a b", "cam/0", "a*", "x" * 65, "caméra", "a$", "a\tb"]


@pytest.mark.parametrize("value", NAMES + NOT_NAMES)
def test_name_patterns_agree_with_check_name(value: str) -> None:
    names = _validator({"type": "string", "pattern": NAME_PATTERN})
    runs = _validator({"type": "string", "pattern": RUN_ID_PATTERN})
    try:
        check_name(value)
        valid = True
    except ProtoError:
        valid = False
    assert names.is_valid(value) == valid
    assert runs.is_valid(value) == (valid or value == "")


def test_a_string_rule_without_a_pattern_has_no_schema() -> None:
    from proto.fields import Str

    with pytest.raises(ValueError, match="no JSON Schema pattern"):
        fragment(Str(validate=lambda value, name: value))
    with pytest.raises(TypeError):
        fragment(object())


# -- golden values -------------------------------------------------------------------------


@pytest.mark.parametrize("kind", list(MESSAGE_TYPES))
def test_golden_json_is_the_decoded_golden_message(
    kind: str, golden_files: dict[str, bytes]
) -> None:
    text = (GOLDEN_DIR / f"{kind}.json").read_text(encoding="utf-8")
    assert golden_json(golden_files[kind]) == text, "regenerate: python -m proto.golden"
    assert json.loads(text) == to_json(decode(golden_files[kind]))


@pytest.mark.parametrize("kind", list(MESSAGE_TYPES))
def test_golden_json_validates_and_packs_to_the_golden_bytes(
    kind: str, golden_files: dict[str, bytes]
) -> None:
    obj = _golden_json(kind)
    errors = list(_validator(_committed_schema(kind)).iter_errors(obj))
    assert not errors, [e.message for e in errors]
    assert _validator(_committed_schema("header")).is_valid(obj["header"])
    assert to_payload(obj) == golden_files[kind]


def test_the_regeneration_script_writes_the_committed_json(tmp_path: Path) -> None:
    from proto.golden import main as golden_main

    assert golden_main([str(tmp_path)]) == 0
    for kind in MESSAGE_TYPES:
        committed = (GOLDEN_DIR / f"{kind}.json").read_bytes()
        assert (tmp_path / f"{kind}.json").read_bytes() == committed


def _header() -> Header:
    return Header("cam0", 3, 10, "fitter", 20, "")


def _edge_messages() -> list[Message]:
    """Valid messages beyond the golden ones: NaN floats, empty and grey arrays, a failed fit."""
    golden = golden_messages()
    status = golden["status"]
    assert isinstance(status, Status)
    fit = golden["fit"]
    assert isinstance(fit, Fit)
    nan_status = Status(
        _header(),
        **{name: getattr(status, name) for name in Status.specs()}
        | {"latency_p50_ms": math.nan, "latency_p99_ms": math.nan},
    )
    failed_fit = Fit(
        _header(),
        **{name: getattr(fit, name) for name in Fit.specs()}
        | {
            "landmarks": np.zeros((0, 2)),
            "similarity": np.zeros(0),
            "appearance": None,
            "warp_path": "none",
            "failed": True,
            "failure_reason": "lost",
        },
    )
    return [
        nan_status,
        failed_fit,
        FaceBoxes(_header(), 640, 480, np.zeros((0, 4)), np.zeros(0)),
        Frame.from_array(_header(), np.arange(6, dtype=np.uint8).reshape(2, 3)),
    ]


@pytest.mark.parametrize("msg", _edge_messages(), ids=lambda m: m.KIND)
def test_json_form_of_other_valid_messages(msg: Message) -> None:
    obj = to_json(msg)
    text = json.dumps(obj, allow_nan=False)  # NaN is written as "NaN"
    assert to_payload(json.loads(text)) == encode(msg)
    errors = list(_validator(_committed_schema(msg.KIND)).iter_errors(obj))
    assert not errors, [e.message for e in errors]


# -- invalid examples ----------------------------------------------------------------------


def test_invalid_cases_are_well_formed() -> None:
    names = [case["name"] for case in CASES]
    assert len(set(names)) == len(names)
    assert {case["base"] for case in CASES} == set(MESSAGE_TYPES)
    for case in CASES:
        assert case["json_schema"] in ("rejects", "accepts"), case["name"]
        assert case["reason"] and case["rule"] and case["patch"], case["name"]
        assert ("note" in case) == (case["json_schema"] == "accepts"), case["name"]


@pytest.mark.parametrize("case", CASES, ids=[case["name"] for case in CASES])
def test_invalid_case_is_rejected_with_its_reason(case: dict[str, Any]) -> None:
    obj = apply_patch(_golden_json(case["base"]), case["patch"])
    with pytest.raises(ProtoError) as caught:
        decode(to_payload(obj))
    assert caught.value.reason == case["reason"]
    valid = _validator(_committed_schema(case["base"])).is_valid(obj)
    assert valid == (case["json_schema"] == "accepts"), case.get("note", "schema should reject")
