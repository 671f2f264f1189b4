"""``aamtrack run --profile``: a classifier made for other fits, or a model without what the
profile's fitting needs, is one line at start (exit 2)."""

from __future__ import annotations

import subprocess
from collections.abc import Callable
from pathlib import Path

from aamcore.fitting.model import FittingModel


def _one_line_exit_2(done: subprocess.CompletedProcess[str], expected: str) -> None:
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert done.returncode == 2, done.stdout + done.stderr
    assert len(lines) == 1 and expected in lines[0], done.stderr
    assert "Traceback" not in done.stdout + done.stderr


def test_what_a_profile_cannot_use_is_refused_at_start(
    run_cli: Callable[..., subprocess.CompletedProcess[str]], single_face: Path,
    model_path: Path, classifier_path: Path, tmp_path: Path,
) -> None:
    video = ["--video", str(single_face), "--no-ar"]
    # the default profile's classifier read the local-binary fits, not the thesis's
    done = run_cli("run", *video, "--profile", "thesis", "--model", str(model_path),
                   "--classifier", str(classifier_path), timeout=120)
    _one_line_exit_2(done, "made for the fits of model")
    assert "by local-binary, not for those of model" in done.stderr
    assert "by fixed-jacobian" in done.stderr
    model = FittingModel.load(model_path)
    bare = FittingModel(model.aam, model.mapping, [], model.cascade, model.binary)
    path = bare.save(tmp_path / "no-updates.npz")
    done = run_cli("run", *video, "--profile", "thesis", "--model", str(path), timeout=120)
    _one_line_exit_2(done, "this model has no update matrix, which fixed-jacobian needs")
