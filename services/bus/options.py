"""Options on the command line and in files: the one option mechanism's doors.

Every option, of the pipeline (:mod:`aamcore.operators.options`, a part per stage) or of a
service process (its Zenoh queue, its bus), is a value of a frozen dataclass declared
with :func:`aamcore.settings.setting` (here :func:`option`, the same with a check function
and an environment variable) or a part of one (:func:`aamcore.settings.group`): one
declaration gives the default, the help, the checks and the flag. From it

- :func:`add_options` adds the values to an ``argparse`` parser (a group per stage with
  ``by_stage``),
- :func:`options_from` builds the checked dataclass from parsed arguments (the
  environment fills what the command line leaves out) over a base (a profile's, a stack
  file's),
- :func:`options_argv` turns a dataclass back into the command line that gives it, which
  is how the launcher starts a service with its options, and
- :func:`options_of_mapping` reads a stack file's table.

A value out of range, or unknown, raises :class:`OptionError` naming the option by its
flag and its stage, before any process starts. This module imports no algorithm.
"""

from __future__ import annotations

import argparse
import difflib
import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from aamcore.settings import NO_VALUE, ConfigError, Setting, Settings, setting

Check = Callable[[Any], str]
"""Returns what is wrong with a value, or ``""``."""


class OptionError(ConfigError):
    """An option's value is not acceptable; the message names the option (and its stage).

    Attributes
    ----------
    option : str or None
        The flat name of the option, when one option is at fault.
    """

    def __init__(self, message: str, option: str | None = None, stage: str = "",
                 cause: ConfigError | None = None) -> None:
        ValueError.__init__(self, message)
        self.field = self.option = option
        self.value, self.problem, self.stage = NO_VALUE, message, stage
        self.cause = cause
        """The configuration's error this one shows (None: a message of its own)."""

    @classmethod
    def of(cls, exc: ConfigError, flag: str | None = None, where: str = "") -> OptionError:
        """``exc`` naming its option by ``flag``, after ``where`` (a stack file's table)."""
        cause = exc.cause if isinstance(exc, OptionError) else exc
        if cause is None:
            return cls(where + str(exc), exc.field, exc.stage)
        shown = ConfigError(cause.field, cause.value, cause.problem, cause.stage, flag)
        return cls(where + str(shown), cause.field, cause.stage, cause)

    def renamed(self, field: str, stage: str = "") -> ConfigError:
        """The configuration's error, renamed (an error of its own message stays)."""
        return self if self.cause is None else self.cause.renamed(field, stage)


def option(default: Any, help: str, *, choices: Sequence[Any] | None = None,
           metavar: str | None = None, env: str | None = None, check: Check | None = None,
           flag: str | None = None, const: Any = None, aliases: Sequence[str] = ()) -> Any:
    """A value of a service's options (:func:`aamcore.settings.setting`): ``env`` is read
    when the command line does not give it, ``check(value)`` says what is wrong with a
    value, ``const`` is the value of the flag given alone, ``aliases`` other flags."""
    return setting(default, help, choices=choices, metavar=metavar, flag=flag, env=env,
                   check=check, const=const, aliases=aliases)


def in_range(low: float, high: float = math.inf) -> Check:
    """A check that a number lies in ``[low, high]``."""

    def check(value: Any) -> str:
        if value is None:
            return ""
        if not (isinstance(value, int | float) and math.isfinite(value) and low <= value <= high):
            upper = "" if high == math.inf else f" to {high:g}"
            return f"must be a number from {low:g}{upper}"
        return ""

    return check


@dataclass(frozen=True)
class Options(Settings):
    """Base of a service's options: checked on construction, errors naming the flag."""

    def __post_init__(self) -> None:
        try:
            super().__post_init__()
        except OptionError:
            raise
        except ConfigError as exc:
            known = {s.name: s.flag for s in self.settings()}
            raise OptionError.of(exc, known.get(exc.field or "")) from None


def _entries(cls: type[Settings], only: Sequence[str] | None = None) -> list[Setting]:
    """The values of ``cls`` (those named in ``only``: by flat name, or a part's field)."""
    return [s for s in cls.settings()
            if only is None or s.name in only or s.path[0] in only]


def flag_of(s: Setting) -> str:
    """The command-line flag of a value."""
    return s.flag


def _help(s: Setting) -> str:
    text = s.help
    if s.default not in (None, (), False, ""):
        text += f" (default {s.default})"
    if s.spec.const is not None:
        text += f" (without a value: {s.spec.const})"
    if s.spec.env:
        text += f" [env {s.spec.env}]"
    return text


def add_options(parser: argparse.ArgumentParser | Any, cls: type[Settings],
                only: Sequence[str] | None = None,
                flags: Mapping[str, Sequence[str]] | None = None, by_stage: bool = False
                ) -> None:
    """Add the values of ``cls`` (those named in ``only``) to ``parser`` or an argument group;
    with ``by_stage``, each stage's in a group of its own (``fit options``).

    ``flags`` gives some options other flags than their own (and their aliases), by flat
    name: ``{"viewer": ("--connect",)}``.
    """
    groups: dict[str, Any] = {}
    for s in _entries(cls, only):
        where = parser
        if by_stage and s.stage:
            if s.stage not in groups:
                groups[s.stage] = parser.add_argument_group(f"{s.stage} options")
            where = groups[s.stage]
        kwargs: dict[str, Any] = {"dest": s.name, "default": None, "help": _help(s)}
        if s.kind is bool:
            kwargs["action"] = argparse.BooleanOptionalAction
        elif s.kind is tuple:
            kwargs.update(action="extend", type=_comma_list, metavar=s.metavar or "VALUE")
        else:
            kwargs.update(type=s.kind, metavar=s.metavar, choices=s.choices)
            if s.spec.const is not None:
                kwargs.update(nargs="?", const=s.spec.const)
        names = (flags or {}).get(s.name) or (s.flag, *s.spec.aliases)
        where.add_argument(*names, **kwargs)


def _comma_list(text: str) -> list[str]:
    """A repeatable option's value: one item, or several separated by commas."""
    return [item.strip() for item in text.split(",") if item.strip()]


def _from_env(name: str, kind: type) -> Any:
    text = os.environ.get(name, "")
    if not text:
        return None
    if kind is tuple:
        return tuple(_comma_list(text))
    if kind is bool:
        return text.lower() in ("1", "true", "yes", "on")
    try:
        return kind(text)
    except ValueError as exc:
        raise OptionError(f"environment variable {name}={text!r}: {exc}") from None


def options_from(cls: type[Settings], args: argparse.Namespace | None = None,
                 only: Sequence[str] | None = None, base: Settings | None = None,
                 flags: Mapping[str, Sequence[str]] | None = None, **given: Any) -> Any:
    """Build ``cls`` from parsed arguments, then the environment, then ``base`` or the defaults.

    Only the values named in ``only`` are read from ``args``; keyword arguments (flat
    names, or a part whole by its field's name) override everything. ``flags``, as given
    to :func:`add_options`, names an option at fault by the flag it was given with.

    Raises
    ------
    OptionError
    """
    values: dict[str, Any] = {}
    for s in _entries(cls, only):
        value = getattr(args, s.name, None) if args is not None else None
        if value is None and s.spec.env:
            value = _from_env(s.spec.env, s.kind)
        if value is not None:
            values[s.name] = tuple(value) if s.kind is tuple else value
    values.update(given)
    return _with_values(base if base is not None else cls(), values, flags)


def _with_values(base: Settings, values: dict[str, Any],
                 flags: Mapping[str, Sequence[str]] | None = None, where: str = "") -> Any:
    try:
        return base.with_values(**values)
    except ConfigError as exc:
        names = (flags or {}).get(exc.field or "")
        flag = names[0] if names else next(
            (s.flag for s in base.settings() if s.name == exc.field), None)
        raise OptionError.of(exc, flag, where) from None


def options_argv(opts: Settings) -> list[str]:
    """The command-line arguments giving ``opts`` back (only values other than the defaults)."""
    argv: list[str] = []
    for s in type(opts).settings():
        value = opts.get(s.path)
        if value == s.default or value is None:
            continue
        if s.kind is bool:
            argv.append(s.flag if value else "--no-" + s.flag[2:])
        elif s.kind is tuple:
            for item in value:
                argv += [s.flag, str(item)]
        else:
            argv += [s.flag, str(value)]
    return argv


def options_of_mapping(cls: type[Settings], data: dict[str, Any], where: str,
                       base: Settings | None = None) -> Any:
    """Build ``cls`` (over ``base``) from a mapping of flat names or flags without their
    dashes (a stack file's table).

    Raises
    ------
    OptionError
        Naming ``where`` for an unknown key or a value of the wrong type.
    """
    entries = {s.name: s for s in cls.settings()}
    entries |= {s.flag[2:].replace("-", "_"): s for s in entries.values()}
    values: dict[str, Any] = {}
    for key, value in data.items():
        name = key.replace("-", "_")
        if name not in entries:
            close = difflib.get_close_matches(name, entries, 1)
            stage = f" ({entries[close[0]].stage} stage)" if close and entries[
                close[0]].stage else ""
            hint = f"did you mean {close[0].replace('_', '-')}{stage}? " if close else ""
            raise OptionError(f"{where}: unknown option {key!r}; {hint}options are "
                              f"{', '.join(sorted({s.name for s in entries.values()}))}",
                              name)
        s = entries[name]
        if s.kind is tuple:
            value = tuple(value) if isinstance(value, list) else (value,)
        elif s.kind is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        elif not isinstance(value, s.kind) or (s.kind is int and isinstance(value, bool)):
            raise OptionError(f"{where}: {key} = {value!r} is not a {s.kind.__name__}", s.name,
                              s.stage)
        values[s.name] = value
    return _with_values(base if base is not None else cls(), values, where=f"{where}: ")
