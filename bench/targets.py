"""A benchmark's targets, declared once beside it, and the one table of met and missed.

A benchmark declares each figure it must reach as a module-level :class:`Target` and
calls :meth:`Target.check` with what it measured; :mod:`bench.tool` prints the checks of
a run in one table (``MET`` or ``MISSED`` per line), and writes them as JSON with
``--json OUT``.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

OPERATORS: dict[str, Callable[[Any, Any], bool]] = {
    "<=": operator.le, "<": operator.lt, ">=": operator.ge, ">": operator.gt, "==": operator.eq}

CHECKS: list[dict[str, Any]] = []
"""What the running benchmark checked, in order (the tool empties it before each run)."""


@dataclass(frozen=True)
class Target:
    """A figure to reach: the measured ``what`` compared by ``op`` to ``limit``.

    A ``limit`` of True is a condition that must hold (``op`` ``==``)."""

    what: str
    op: str
    limit: float | bool
    unit: str = ""

    def __post_init__(self) -> None:
        if self.op not in OPERATORS:
            raise ValueError(f"target {self.what!r}: unknown comparison {self.op!r}")

    def met(self, value: float | bool) -> bool:
        """Whether ``value`` reaches the target (a NaN never does)."""
        if isinstance(value, float) and math.isnan(value):
            return False
        return bool(OPERATORS[self.op](value, self.limit))

    def check(self, value: float | bool, detail: str = "") -> bool:
        """Record ``value`` (with a ``detail`` of where or how) for the table; whether met."""
        met = self.met(value)
        CHECKS.append({"target": self.what, "op": self.op, "limit": _plain(self.limit),
                       "unit": self.unit, "value": _plain(value), "met": met,
                       "detail": detail})
        return met

    def wanted(self) -> str:
        """The target as text: ``>= 1000 fits/s``, ``yes``."""
        if isinstance(self.limit, bool):
            return "yes" if self.limit else "no"
        return f"{self.op} {number(self.limit)}{_unit(self.unit)}"


def _plain(value: float | bool) -> float | bool | None:
    """A JSON-safe value: a Python bool or float, None for NaN or infinity."""
    if isinstance(value, bool):
        return value
    value = float(value)
    return value if math.isfinite(value) else None


def _unit(unit: str) -> str:
    return unit if unit in ("", "%", "x") else f" {unit}"


def number(value: float | bool | None) -> str:
    """A measured figure as the table prints it."""
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return "yes" if value else "no"
    return f"{value:,.0f}" if abs(value) >= 1000 else f"{value:.3g}"


def table(checks: Sequence[dict[str, Any]], declared: Sequence[Target] = ()) -> list[str]:
    """The lines of the targets table: each check MET or MISSED with its figure, then each
    declared target no check measured as NOT RUN."""
    lines = []
    for c in checks:
        measured = number(c["value"]) + _unit(c["unit"]) if not isinstance(
            c["limit"], bool) else number(c["value"])
        wanted = Target(c["target"], c["op"], c["limit"], c["unit"]).wanted()
        detail = f"  ({c['detail']})" if c["detail"] else ""
        lines.append(f"{'MET' if c['met'] else 'MISSED':<8}{c['target']}: {measured} "
                     f"(target {wanted}){detail}")
    seen = {c["target"] for c in checks}
    lines += [f"{'NOT RUN':<8}{t.what} (target {t.wanted()})"
              for t in declared if t.what not in seen]
    return lines
