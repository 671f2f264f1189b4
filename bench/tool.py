"""The bench tool: every benchmark by name, run with the shared options, one targets table.

``python -m bench`` (or ``--list``) names each benchmark with one line;
``python -m bench NAME [options]`` runs one (``NAME --help`` for its options) and ends with
its targets, each MET or MISSED; ``--json OUT`` writes that table as JSON. Exit status 0
when every target checked is met, 1 when one is missed or the benchmark fails, 2 for a bad
name or option.
"""

from __future__ import annotations

import argparse
import ast
import importlib
import json
import os
import re
import sys
import time
from pathlib import Path

from bench import targets

HERE = Path(__file__).resolve().parent

BENCHMARKS = (
    "models", "fit-imm", "fit-lfpw", "fit-speed", "occlusion", "ar-cover", "thesis-profile",
    "vs-dlib", "vs-mediapipe",
    "detector-tuning", "detection", "facemark", "failure-tests", "smoothing", "tracking",
    "multiface", "no-face", "posit", "pose-e2e", "pose-speed", "pose-yaw", "expression",
    "expression-degraded",
    "prepare", "first-command", "first-minutes", "gl-warp", "stack", "stack-vs-library",
    "frame-transport", "signing", "faults", "soak", "flood", "attacks", "reliability",
    "deploy",
)
"""Every benchmark, by name: ``fit-speed`` is ``bench/bench_fit_speed.py``."""


def module_of(name: str) -> str:
    return f"bench.bench_{name.replace('-', '_')}"


def summary(name: str) -> str:
    """The first line of a benchmark's docstring, read without importing it."""
    path = HERE / f"bench_{name.replace('-', '_')}.py"
    doc = ast.get_docstring(ast.parse(path.read_text())) or ""
    line = re.sub(r"^([\w-]+ )?(bench|benchmark)( \(issue \d+\))?:? ", "",
                  doc.split("\n\n")[0].replace("\n", " ").replace("``", ""),
                  flags=re.IGNORECASE)
    return line[:1].upper() + line[1:]


def listing() -> str:
    width = max(map(len, BENCHMARKS)) + 2
    return "\n".join(f"  {name:<{width}}{summary(name)}" for name in BENCHMARKS)


def usage() -> str:
    return ("usage: python -m bench [--list] | python -m bench NAME [--model FILE] "
            "[--data DIR] [--json OUT] [NAME's options]\n\nbenchmarks:\n" + listing())


def run(name: str, argv: list[str]) -> int:
    """Run one benchmark; print its targets table (and write it with ``--json``)."""
    out = argparse.ArgumentParser(add_help=False)
    out.add_argument("--json", type=Path)
    json_path = out.parse_known_args(argv)[0].json
    try:
        module = importlib.import_module(module_of(name))
    except ModuleNotFoundError as exc:
        print(f"python -m bench {name}: needs {exc.name}, which is not installed (the peers: "
              "pip install -e '.[bench]')", file=sys.stderr)
        return 2
    declared = getattr(module, "TARGETS", ())
    targets.CHECKS.clear()
    load, start = os.getloadavg()[0], time.perf_counter()
    try:
        code = module.main(argv) or 0
    except KeyboardInterrupt:
        code = 130
    seconds = time.perf_counter() - start
    checks = list(targets.CHECKS)
    missed = sum(not c["met"] for c in checks)
    print(f"\n{name}: {len(checks) - missed} of {len(checks)} targets met, {seconds:.0f} s, "
          f"load {load:.1f} -> {os.getloadavg()[0]:.1f}")
    lines = targets.table(checks, declared)
    print("\n".join(lines) if lines else "(no targets: a measurement only)")
    result = 1 if code or missed else 0
    if json_path is not None:
        record = {"benchmark": name, "argv": argv, "exit": result, "seconds": seconds,
                  "load": [load, os.getloadavg()[0]], "targets": checks,
                  "not_run": [t.what for t in declared
                              if t.what not in {c["target"] for c in checks}]}
        json_path.write_text(json.dumps(record, indent=1) + "\n")
    return result


def main(argv: list[str]) -> int:
    if not argv or argv[0] in ("--list", "-l"):
        print(listing())
        return 0
    if argv[0] in ("-h", "--help"):
        print(__doc__.split("\n\n")[1].replace("\n", " ") + "\n\n" + usage())
        return 0
    name = argv[0]
    if name not in BENCHMARKS:
        print(f"python -m bench: unknown benchmark {name!r}; the benchmarks:\n{listing()}",
              file=sys.stderr)
        return 2
    return run(name, argv[1:])
