"""The expression codes and the reasons are explained where a user looks: the README, the
help of ``track``, ``export`` and ``run``, and the CSV's notes (``aamcore/results.py``)."""

from __future__ import annotations

import argparse

import pytest

import aamcore.results as results
from aamcore.config import REPO_ROOT
from services.cli import build_parser


def _help(command: str) -> str:
    parser = build_parser(command)
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return " ".join(sub.choices[command].format_help().split())


@pytest.mark.parametrize("command", ["track", "export", "run"])
def test_help_gives_every_code_and_reason(command: str) -> None:
    text = _help(command)
    for code, word in results.EXPRESSIONS.items():
        assert f"{code} {word}" in text
    for reason in (*results.EXPRESSION_REASONS, *results.REASONS):
        assert reason in text, reason


def test_readme_and_csv_notes_explain_every_code_and_reason() -> None:
    readme = " ".join((REPO_ROOT / "README.md").read_text().split())
    for code, word in results.EXPRESSIONS.items():
        assert f"**{code}** {word}" in readme
        assert f"{code} {word.split()[0]}" in " ".join((results.__doc__ or "").split())
    for reason in (*results.EXPRESSION_REASONS, *results.REASONS):
        assert f"`{reason}`" in readme, reason


def test_a_reason_is_explained_by_the_phrase_it_starts_with() -> None:
    assert results.explained("face in profile: turned about 52 degrees (at most 40)",
                             results.EXPRESSION_REASONS) == "face in profile"
    assert results.explained("face in profile or badly fitted: it matches its mirror image "
                             "0.41", results.EXPRESSION_REASONS) == (
        "face in profile or badly fitted")
    assert results.explained("fit-quality score 1.20 above 0.90 (predicted NME 3.320)",
                             results.REASONS) == "fit-quality score"
    assert results.explained("", results.REASONS) == ""
