"""services.cli: help comes without the algorithms, every command is listed where it is
registered, Ctrl-C at any moment ends a command with one line and exit code 130."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from aamcore.config import REPO_ROOT
from services.cli import build_parser, command_in
from services.cli.commands import COMMANDS

HEAVY = ("numpy", "cv2", "sklearn", "scipy", "zenoh", "moderngl", "rerun", "msgpack", "tqdm",
         "matplotlib", "skimage")
"""Packages that help must not import: what the algorithms, the bus and the codec need."""
HELP_ARGV = [["--help"], *([name, "--help"] for name in COMMANDS),
             ["model", "prepare", "--help"], ["eval", "fit", "--help"],
             ["eval", "pose", "--help"], ["eval", "expression", "--help"],
             ["service", "fitter", "--help"], ["models", "show", "--help"]]
_ASK_FOR_HELP = """
import json, sys
from services.cli import main
for argv in json.loads(sys.argv[1]):
    try:
        main(argv)
    except SystemExit as exc:
        assert exc.code == 0, (argv, exc.code)
print(json.dumps(sorted(sys.modules)))
"""


def _env() -> dict[str, str]:
    return os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO_ROOT)}


def test_help_imports_no_algorithm() -> None:
    """Every command's help, in one process (~1 s): the modules it loaded, all of them."""
    done = subprocess.run([sys.executable, "-c", _ASK_FOR_HELP, json.dumps(HELP_ARGV)],
                          capture_output=True, text=True, timeout=120, env=_env(), cwd=REPO_ROOT)
    assert done.returncode == 0, done.stderr[-2000:]
    loaded = json.loads(done.stdout.splitlines()[-1])
    heavy = sorted({m.split(".")[0] for m in loaded} & set(HEAVY))
    assert not heavy, f"help imported {heavy}"
    assert "aamcore.tracker" not in loaded and "services.stack.launcher" not in loaded


def test_every_command_is_listed_where_it_is_registered() -> None:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, __import__("argparse")
                                                          ._SubParsersAction))
    listed = {a.dest: a.help for a in sub._choices_actions}
    assert listed == {name: c.help for name, c in COMMANDS.items()}
    assert sub.choices["models"] is sub.choices["model"]


def test_the_command_word_is_found_after_global_options() -> None:
    assert command_in(["-v", "track", "x.mp4"]) == "track"
    assert command_in(["--help"]) == ""
    with pytest.raises(SystemExit):
        build_parser("trakc").parse_args(["trakc"])  # a typo: argparse names the choices


def _interrupt_when(argv: list[str], marker: str, script: list[str] | None = None
                    ) -> tuple[int, list[str]]:
    """Run ``python -X importtime -m services ARGV`` (or the ``script`` given), send SIGINT
    once the import of module ``marker`` is timed; the exit code and the standard error
    lines that are not import times."""
    child = subprocess.Popen([sys.executable, "-X", "importtime",
                              *(script or ["-m", "services"]), *argv],
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                             env=_env(), cwd=REPO_ROOT,
                             preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert child.stderr is not None
    lines = []
    for line in child.stderr:
        if not line.startswith("import time:"):
            lines.append(line.rstrip("\n"))
        if line.rsplit("|", 1)[-1].strip() == marker:
            child.send_signal(signal.SIGINT)
            break
    lines += [x for x in child.stderr.read().splitlines() if not x.startswith("import time:")]
    return child.wait(timeout=60), lines


def test_ctrl_c_while_importing_ends_with_one_line(single_face: Path, tmp_path: Path) -> None:
    """Interrupted while the command imports numpy (~2 s): exit 130, one line."""
    code, lines = _interrupt_when(["track", str(single_face), "--csv", str(tmp_path / "o.csv")],
                                  "numpy._core.multiarray")
    assert (code, lines) == (130, ["aamtrack track: interrupted"])


def test_ctrl_c_while_the_console_command_imports_its_first_module_ends_with_one_line(
    tmp_path: Path,
) -> None:
    """The ``aamtrack`` console script, interrupted as it makes itself non-dumpable (its
    first import, before ``main`` and its handling exist): exit 130, one line."""
    script = tmp_path / "aamtrack"  # what pip writes for [project.scripts]
    script.write_text("import sys\nfrom services.cli import main\nsys.exit(main())\n")
    code, lines = _interrupt_when(["run", "--help"], "ctypes", [str(script)])
    # "aamtrack: interrupted" while it imports, "aamtrack run: ..." once main() runs.
    assert code == 130 and len(lines) == 1 and lines[0].endswith(": interrupted"), lines
