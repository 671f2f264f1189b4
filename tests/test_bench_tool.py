"""``python -m bench``: every benchmark listed and registered, one run end to end through
the tool (its targets MET or MISSED, the JSON), and a bad name refused."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

from aamcore.config import REPO_ROOT
from bench import tool
from bench.targets import Target


def bench(*argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "bench", *argv], cwd=REPO_ROOT,
                          capture_output=True, text=True, timeout=120)


def test_every_benchmark_file_is_registered_and_listed() -> None:
    files = {p.stem.removeprefix("bench_").replace("_", "-")
             for p in (REPO_ROOT / "bench").glob("bench_*.py")}
    assert files == set(tool.BENCHMARKS)
    done = bench("--list")
    assert done.returncode == 0, done.stderr
    listed = [line.split()[0] for line in done.stdout.splitlines() if line.strip()]
    assert listed == list(tool.BENCHMARKS)
    assert all(len(line.split()) > 2 for line in done.stdout.splitlines())


def test_the_readme_names_every_benchmark_and_runs_them_through_the_tool() -> None:
    readme = (REPO_ROOT / "README.md").read_text()
    table = readme[readme.index("## Benchmarks"):]
    rows = [line for line in table.splitlines() if line.startswith("| `")]
    named = {n.strip("` ") for row in rows for n in row.split("|")[1].split(",")}
    assert named == set(tool.BENCHMARKS)
    assert not re.search(r"bench/bench_\w+\.py|python bench/", readme)


def test_every_benchmark_has_a_main_and_its_verdicts_go_through_its_targets() -> None:
    """Each module has the tool's entry and the shared parser, edits no ``sys.path`` and
    prints no verdict of its own: its targets are declared (``TARGETS``) and checked."""
    for name in tool.BENCHMARKS:
        path = REPO_ROOT / "bench" / f"bench_{name.replace('-', '_')}.py"
        text = path.read_text()
        assert "sys.path" not in text, path
        assert "def main(argv: list[str] | None = None)" in text, path
        assert "options.parser(__doc__, __name__" in text, path
        assert not re.search(r"['\"](PASS|FAIL)['\" ]|\b(PASS|FAIL): ", text), path
        assert ("\nTARGETS = " in text) == (".check(" in text and "Target(" in text), path


def test_a_benchmark_runs_through_the_tool(tmp_path: Path) -> None:
    out = tmp_path / "posit.json"
    done = bench("posit", "--trials", "20", "--skip-subsets", "--json", str(out))
    assert done.returncode in (0, 1), done.stderr
    table = [line for line in done.stdout.splitlines()
             if line.startswith(("MET", "MISSED", "NOT RUN"))]
    assert len(table) == 5 and sum(line.startswith("NOT RUN") for line in table) == 1
    record = json.loads(out.read_text())
    assert record["benchmark"] == "posit" and len(record["targets"]) == 4
    assert record["exit"] == (0 if all(t["met"] for t in record["targets"]) else 1)
    assert record["exit"] == done.returncode
    for row in record["targets"]:
        assert row["met"] == Target(row["target"], row["op"], row["limit"]).met(row["value"])


def test_an_unknown_benchmark_exits_2_with_one_line_and_the_list() -> None:
    done = bench("no-such-bench")
    assert done.returncode == 2
    first, *rest = done.stderr.splitlines()
    assert "no-such-bench" in first
    assert [line.split()[0] for line in rest] == list(tool.BENCHMARKS)
    assert "Traceback" not in done.stderr


def test_a_bad_option_gets_the_benchmarks_usage() -> None:
    done = bench("posit", "--no-such-option")
    assert done.returncode == 2
    assert done.stderr.startswith("usage: python -m bench posit")


def test_a_target_compares_as_declared() -> None:
    fast = Target("rate", ">=", 30.0, "frames/s")
    assert fast.met(30.0) and not fast.met(29.9) and not fast.met(float("nan"))
    assert Target("answered", "==", True).met(True)
    assert not Target("answered", "==", True).met(False)
