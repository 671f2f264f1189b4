"""The layout ARCHITECTURE.md describes holds: imports flow one way, modules and functions
stay short enough to read."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from aamcore.config import REPO_ROOT

PACKAGES = ("aamcore", "proto", "services")
FORBIDDEN = {
    "aamcore": ("services", "proto", "zenoh", "rerun"),
    "proto": ("aamcore", "services", "cv2", "rerun", "moderngl"),
}
"""What each package must not import: the library knows no bus, the contract no algorithm."""
MAX_MODULE_LINES = 400
MAX_FUNCTION_LINES = 60


def modules(package: str) -> list[Path]:
    return sorted((REPO_ROOT / package).rglob("*.py"))


def imported(tree: ast.AST) -> set[str]:
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_imports_flow_one_way(package: str) -> None:
    offenders = []
    for path in modules(package):
        bad = imported(ast.parse(path.read_text())) & set(FORBIDDEN[package])
        if bad:
            offenders.append(f"{path.relative_to(REPO_ROOT)} imports {sorted(bad)}")
    assert not offenders, offenders


@pytest.mark.parametrize("package", PACKAGES)
def test_modules_and_functions_are_short(package: str) -> None:
    long = []
    for path in modules(package):
        text = path.read_text()
        name = path.relative_to(REPO_ROOT)
        if text.count("\n") > MAX_MODULE_LINES:
            long.append(f"{name}: {text.count(chr(10))} lines")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                size = node.end_lineno - node.lineno + 1
                if size > MAX_FUNCTION_LINES:
                    long.append(f"{name}:{node.lineno} {node.name}: {size} lines")
    assert not long, long


def test_every_package_folder_is_documented() -> None:
    text = (REPO_ROOT / "ARCHITECTURE.md").read_text()
    for package in ("aamcore", "services"):
        for folder in sorted(p for p in (REPO_ROOT / package).iterdir()
                             if p.is_dir() and (p / "__init__.py").exists()):
            assert f"{folder.name}/" in text, f"ARCHITECTURE.md misses {package}/{folder.name}/"
