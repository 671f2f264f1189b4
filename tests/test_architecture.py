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


LAYERS = (
    ("config", "defaults", "progress", "reproducible", "settings", "smoothing"),
    ("io",),
    ("warp",),
    ("model",),
    ("detection",),
    ("fitting",),
    ("pose",),
    ("expression",),
    ("ar", "synth"),
    ("operators",),
    ("evaluation",),
    ("profiles",),
    ("tracker", "results", "face_result", "annotate"),
)
"""The stages of aamcore from the bottom up, as ARCHITECTURE.md draws them: a module may
import its own stage and those below, never one above."""
PENDING: set[tuple[str, str]] = set()
"""Arrows up still to be moved (none left)."""


FITTING_LAYERS = (
    ("result", "shape_space", "pyramid", "residuals", "features", "search", "upright",
     "warps", "occluders"),
    ("algorithm.ferns", "algorithm.local_hog", "learned", "update_matrix", "occlusion",
     "appearance"),
    ("model",),
    ("algorithm",),
    ("config", "failure"),
    ("fitter",),
    ("tracker", "multi"),
    ("training",),
)
"""The layers inside ``aamcore/fitting`` from the bottom up: fits and image tools; what
the methods learn (stored in the model); the model; the methods (``algorithm/``, the
registry names them all); the choices and failure tests; the fitter; the trackers; and
training on top, which nothing that runs imports."""
TRAINING_DOORS = {"aamcore/profiles.py"}
"""The one module of the library outside ``fitting/training`` that reaches training: a
profile's model, trained and cached on first use (:meth:`aamcore.profiles.Profile.model_path`)."""


def _stage(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if parts[0] == "aamcore" and len(parts) > 1 else None


def _fitting_layer(module: str) -> str | None:
    """The layer name of a module of ``aamcore.fitting`` (``algorithm.ferns``, ``model``),
    None for another module or the package itself."""
    parts = module.split(".")
    if parts[:2] != ["aamcore", "fitting"] or len(parts) < 3:
        return None
    if len(parts) > 3 and ".".join(parts[2:4]) in {n for layer in FITTING_LAYERS for n in layer}:
        return ".".join(parts[2:4])
    return parts[2]


def _imports(path: Path) -> list[str]:
    """Every module ``path`` imports, ``importlib.import_module`` targets of the ALGORITHMS
    registry included (as written in the file)."""
    tree = ast.parse(path.read_text())
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found += [f"{node.module}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            found += [a.name for a in node.names]
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            target = node.value.split(":")[0]  # "aamcore.fitting.algorithm.x:Class"
            if target.startswith("aamcore.") and target.count(".") >= 2 and " " not in target:
                found.append(target)
    return found


def test_the_stages_of_aamcore_import_only_downwards() -> None:
    rank = {name: k for k, layer in enumerate(LAYERS) for name in layer}
    assert set(rank) >= {p.stem if p.is_file() else p.name for p in (REPO_ROOT / "aamcore")
                         .iterdir() if p.name != "__init__.py" and not p.name.startswith("_")
                         and (p.suffix == ".py" or (p / "__init__.py").exists())}
    up = set()
    for path in modules("aamcore"):
        me = _stage(".".join(path.relative_to(REPO_ROOT).with_suffix("").parts))
        if me is None or me == "__init__":
            continue
        for target in _imports(path):
            other = _stage(target)
            if other in rank and me in rank and rank[other] > rank[me]:
                up.add((me, other, path.relative_to(REPO_ROOT).as_posix()))
    assert {(a, b) for a, b, _ in up} <= PENDING, sorted(up)


def test_the_layers_inside_fitting_import_only_downwards() -> None:
    rank = {name: k for k, layer in enumerate(FITTING_LAYERS) for name in layer}
    folder = REPO_ROOT / "aamcore" / "fitting"
    present = {p.stem if p.is_file() else p.name for p in folder.iterdir()
               if p.name != "__init__.py" and (p.suffix == ".py" or (p / "__init__.py").exists())}
    assert set(rank) >= present, present - set(rank)
    up = set()
    for path in sorted(folder.rglob("*.py")):
        name = ".".join(path.relative_to(REPO_ROOT).with_suffix("").parts)
        me = _fitting_layer(name)
        for target in _imports(path):
            other = _fitting_layer(target)
            if me in rank and other in rank and rank[other] > rank[me]:
                up.add(f"{path.relative_to(REPO_ROOT)} ({me}) imports {target} ({other})")
    assert not up, sorted(up)


def test_running_code_imports_no_training_code() -> None:
    """Outside ``fitting/training``, only :data:`TRAINING_DOORS` in the library and the
    commands (``services/cli``, which train and measure) import training; no service."""
    offenders = []
    for package in ("aamcore", "services"):
        for path in modules(package):
            name = path.relative_to(REPO_ROOT).as_posix()
            if (name.startswith(("aamcore/fitting/training/", "services/cli/"))
                    or name in TRAINING_DOORS):
                continue
            if any(t.startswith("aamcore.fitting.training") for t in _imports(path)):
                offenders.append(name)
    assert not offenders, offenders


def test_no_import_loops_in_the_packages() -> None:
    names = {}
    for package in PACKAGES:
        for path in modules(package):
            name = ".".join(path.relative_to(REPO_ROOT).with_suffix("").parts)
            names[name.removesuffix(".__init__")] = path
    graph = {}
    for name, path in names.items():
        targets = set()
        for target in _imports(path):
            while target and target not in names:
                target = target.rpartition(".")[0]
            if target and target != name and not (name.startswith(target + ".")):
                targets.add(target)
        graph[name] = targets
    loops = [c for c in _cycles(graph) if len(c) > 1]
    assert not loops, loops


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of ``graph`` (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on.discard(member)
                    component.append(member)
                    if member == node:
                        break
                out.append(component)
    return out


def test_the_bus_layer_knows_no_algorithm() -> None:
    """Of the library, the bus layer reads only the options mechanism (the standard library
    alone), whose doors it makes."""
    offenders = []
    for path in (REPO_ROOT / "services" / "bus").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            offenders += [f"{path.relative_to(REPO_ROOT)}: {n}" for n in names
                          if n.split(".")[0] == "aamcore" and n != "aamcore.settings"]
    assert not offenders, offenders


SERVING = ("aamcore.tracker", "aamcore.annotate", "services.cli", "services.stack.launcher",
           *(f"services.{name}.service" for name in ("source", "detector", "fitter", "pose",
                                                     "expression", "ar", "rerun_logger")))
"""What a run and every command start with."""
TRAINING_ONLY = ("sklearn", "scipy.optimize", "scipy.stats")
"""Imported by training alone: about a second of every process's start-up when not."""


def test_serving_starts_without_the_training_libraries() -> None:
    import subprocess
    import sys

    code = (f"import importlib, sys\nfor m in {SERVING!r}: importlib.import_module(m)\n"
            f"print(sorted(m for m in {TRAINING_ONLY!r} if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=REPO_ROOT, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]", done.stdout
