"""The README's first command, run as the README gives it, with what the README promises of it.

``./scripts/demo.sh`` is run as written; the one thing the test changes is the model, the
small one the tests train (the script passes its options to ``aamtrack run``), and the
folder it writes to (``AAMTRACK_OUT``). A first command that breaks, or that prints a
warning or a traceback, cannot land again.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

from aamcore.config import REPO_ROOT

RERUN_CLI = Path(sys.executable).with_name("rerun")
NOISE = re.compile(r"warn|traceback|deprecat|error:|exception", re.IGNORECASE)
"""What no line of a clean run may hold (pip's, setuptools', Rerun's and Python's own)."""


def first_command() -> str:
    """The first line of the README's "Two commands" block, without its comment."""
    readme = (REPO_ROOT / "README.md").read_text()
    block = readme.split("## Two commands", 1)[1].split("```sh", 1)[1].split("```", 1)[0]
    return block.strip().splitlines()[0].split("#", 1)[0].strip()


def test_the_first_command_runs_as_the_readme_says(
    model_path: Path, classifier_path: Path, data_dir: Path, tmp_path: Path,
) -> None:
    command = first_command()
    assert command == "./scripts/demo.sh"
    out = tmp_path / "out"
    env = os.environ | {"AAMTRACK_DATA": str(data_dir), "AAMTRACK_OUT": str(out)}
    done = subprocess.run([str(REPO_ROOT / command), "--model", str(model_path),
                           "--classifier", str(classifier_path)], cwd=REPO_ROOT, env=env,
                          capture_output=True, text=True, timeout=600)
    said = done.stdout + done.stderr
    assert done.returncode == 0, said
    assert not [line for line in said.splitlines() if NOISE.search(line)], said
    # What the README promises: the run's summary, a recording Rerun accepts, every result
    # message, the summary as JSON; then the IMM model's figures.
    assert "end of stream: 72 frames (end_of_file)" in done.stdout
    summary = json.loads((out / "run_summary.json").read_text())
    assert summary["total_frames"] == 72 and summary["unanswered"] == {"fit": 0, "pose": 0}
    assert summary["frames_with"]["fit"] > 0 and summary["frames_with"]["pose"] > 0
    verified = subprocess.run([str(RERUN_CLI), "rrd", "verify", str(out / "run.rrd")],
                              capture_output=True, text=True, timeout=120)
    assert verified.returncode == 0, verified.stdout + verified.stderr
    assert (out / "run.rec").stat().st_size > 0
    for figure in ("imm_modes.png", "imm_reconstruction.png"):
        assert (out / figure).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
